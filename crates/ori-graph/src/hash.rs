//! Content hashes and job keys.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// A blake3 digest: of a blob's bytes (content hash) or of a job's identity (job key).
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ContentHash(pub [u8; 32]);

impl ContentHash {
    /// Hash of `bytes`.
    pub fn of(bytes: &[u8]) -> ContentHash {
        ContentHash(*blake3::hash(bytes).as_bytes())
    }

    /// Lower-case hex, 64 characters.
    pub fn to_hex(&self) -> String {
        blake3::Hash::from_bytes(self.0).to_hex().to_string()
    }

    /// The first 12 hex digits, for messages.
    pub fn short(&self) -> String {
        self.to_hex()[..12].to_string()
    }
}

impl fmt::Display for ContentHash {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.to_hex())
    }
}

impl fmt::Debug for ContentHash {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ContentHash({})", self.short())
    }
}

impl FromStr for ContentHash {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        blake3::Hash::from_hex(s)
            .map(|h| ContentHash(*h.as_bytes()))
            .map_err(|e| format!("bad hash `{s}`: {e}"))
    }
}

impl Serialize for ContentHash {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.to_hex())
    }
}

impl<'de> Deserialize<'de> for ContentHash {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

/// Canonical JSON text of `value`: object keys sorted, no whitespace. Two parameter sets that
/// mean the same give the same text whatever order they were written in.
pub fn canonical_json(value: &serde_json::Value) -> String {
    fn write(v: &serde_json::Value, out: &mut Vec<u8>) {
        match v {
            serde_json::Value::Object(map) => {
                let mut entries: Vec<(&String, &serde_json::Value)> = map.iter().collect();
                entries.sort_unstable_by(|a, b| a.0.cmp(b.0));
                out.push(b'{');
                for (i, (k, v)) in entries.into_iter().enumerate() {
                    if i > 0 {
                        out.push(b',');
                    }
                    serde_json::to_writer(&mut *out, k).expect("a string serialises");
                    out.push(b':');
                    write(v, out);
                }
                out.push(b'}');
            }
            serde_json::Value::Array(items) => {
                out.push(b'[');
                for (i, item) in items.iter().enumerate() {
                    if i > 0 {
                        out.push(b',');
                    }
                    write(item, out);
                }
                out.push(b']');
            }
            scalar => serde_json::to_writer(&mut *out, scalar).expect("a scalar serialises"),
        }
    }
    let mut out = Vec::with_capacity(256);
    write(value, &mut out);
    String::from_utf8(out).expect("JSON text is UTF-8")
}

/// The key of a job: blake3 over (stage name, stage version, canonical parameters, and the
/// named content hashes of its inputs, in order). Every field is length-prefixed so no two
/// different jobs can produce the same byte stream.
pub fn job_key(
    stage: &str,
    version: u32,
    params: &serde_json::Value,
    inputs: &[(String, ContentHash)],
) -> ContentHash {
    let mut h = blake3::Hasher::new();
    let mut field = |bytes: &[u8]| {
        h.update(&(bytes.len() as u64).to_le_bytes());
        h.update(bytes);
    };
    field(b"ori-graph job key v1");
    field(stage.as_bytes());
    field(&version.to_le_bytes());
    field(canonical_json(params).as_bytes());
    field(&(inputs.len() as u64).to_le_bytes());
    for (name, hash) in inputs {
        field(name.as_bytes());
        field(&hash.0);
    }
    ContentHash(*h.finalize().as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn canonical_json_sorts_keys_at_every_level() {
        let a = json!({"b": 1, "a": {"y": [1, {"q": 2, "p": 1}], "x": 0.5}});
        assert_eq!(
            canonical_json(&a),
            r#"{"a":{"x":0.5,"y":[1,{"p":1,"q":2}]},"b":1}"#
        );
    }

    #[test]
    fn key_depends_on_every_field() {
        let h = ContentHash::of(b"mesh");
        let base = job_key("bake", 1, &json!({"n": 20}), &[("mesh".into(), h)]);
        assert_ne!(
            base,
            job_key("bake2", 1, &json!({"n": 20}), &[("mesh".into(), h)])
        );
        assert_ne!(
            base,
            job_key("bake", 2, &json!({"n": 20}), &[("mesh".into(), h)])
        );
        assert_ne!(
            base,
            job_key("bake", 1, &json!({"n": 21}), &[("mesh".into(), h)])
        );
        assert_ne!(
            base,
            job_key("bake", 1, &json!({"n": 20}), &[("other".into(), h)])
        );
        let h2 = ContentHash::of(b"mesh2");
        assert_ne!(
            base,
            job_key("bake", 1, &json!({"n": 20}), &[("mesh".into(), h2)])
        );
        assert_eq!(
            base,
            job_key("bake", 1, &json!({"n": 20}), &[("mesh".into(), h)])
        );
    }

    #[test]
    fn hex_round_trip() {
        let h = ContentHash::of(b"x");
        assert_eq!(h.to_hex().parse::<ContentHash>().unwrap(), h);
        assert!("zz".parse::<ContentHash>().is_err());
    }
}
