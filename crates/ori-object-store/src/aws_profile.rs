//! Keys and region from the AWS shared files (`~/.aws/credentials`, `~/.aws/config`), which the
//! AWS command line and SDKs write, for builders whose environment names no keys.

use std::path::PathBuf;

use object_store::aws::{AmazonS3Builder, AmazonS3ConfigKey};

/// Files larger than this are not AWS profile files.
const MAX_FILE_BYTES: u64 = 1 << 20;

/// `builder` with the keys (and region) of the profile `AWS_PROFILE` (or `default`) when the
/// environment sets no `AWS_ACCESS_KEY_ID`. A missing file or profile changes nothing (the
/// instance's role may still serve); a profile with an access key and no secret is an error.
pub fn with_profile_credentials(builder: AmazonS3Builder) -> Result<AmazonS3Builder, String> {
    if std::env::var_os("AWS_ACCESS_KEY_ID").is_some() {
        return Ok(builder);
    }
    let profile = std::env::var("AWS_PROFILE").unwrap_or_else(|_| "default".to_string());
    let mut builder = builder;
    if let Some(path) = aws_file("AWS_SHARED_CREDENTIALS_FILE", "credentials")
        && let Some(values) = read_section(&path, &profile)?
    {
        let value = |key: &str| values.iter().find(|(k, _)| k == key).map(|(_, v)| v);
        match (value("aws_access_key_id"), value("aws_secret_access_key")) {
            (Some(id), Some(secret)) => {
                builder = builder
                    .with_access_key_id(id)
                    .with_secret_access_key(secret);
                if let Some(token) = value("aws_session_token") {
                    builder = builder.with_token(token);
                }
            }
            (None, None) => {}
            _ => {
                return Err(format!(
                    "{}: profile [{profile}] needs both aws_access_key_id and aws_secret_access_key",
                    path.display()
                ));
            }
        }
    }
    let region_set = ["AWS_REGION", "AWS_DEFAULT_REGION"]
        .iter()
        .any(|v| std::env::var_os(v).is_some());
    if !region_set && let Some(path) = aws_file("AWS_CONFIG_FILE", "config") {
        let section = if profile == "default" {
            profile.clone()
        } else {
            format!("profile {profile}")
        };
        if let Some(values) = read_section(&path, &section)?
            && let Some((_, region)) = values.iter().find(|(k, _)| k == "region")
        {
            builder = builder.with_config(AmazonS3ConfigKey::Region, region);
        }
    }
    Ok(builder)
}

/// The file named by `variable`, or `~/.aws/{name}`.
fn aws_file(variable: &str, name: &str) -> Option<PathBuf> {
    match std::env::var_os(variable) {
        Some(path) => Some(PathBuf::from(path)),
        None => std::env::var_os("HOME").map(|home| PathBuf::from(home).join(".aws").join(name)),
    }
}

/// The `key = value` lines of `[section]` in an INI file; `None` when the file or the
/// section does not exist.
fn read_section(
    path: &std::path::Path,
    section: &str,
) -> Result<Option<Vec<(String, String)>>, String> {
    let text = match std::fs::metadata(path) {
        Err(_) => return Ok(None),
        Ok(meta) if meta.len() > MAX_FILE_BYTES => {
            return Err(format!(
                "{}: larger than {MAX_FILE_BYTES} bytes, not an AWS profile file",
                path.display()
            ));
        }
        Ok(_) => std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?,
    };
    Ok(parse_section(&text, section))
}

fn parse_section(text: &str, section: &str) -> Option<Vec<(String, String)>> {
    let mut found = None;
    let mut inside = false;
    for line in text.lines() {
        let line = line.trim();
        if line.is_empty() || line.starts_with(['#', ';']) {
            continue;
        }
        if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            inside = name.trim() == section;
            if inside {
                found.get_or_insert_with(Vec::new);
            }
            continue;
        }
        if inside && let Some((key, value)) = line.split_once('=') {
            found
                .get_or_insert_with(Vec::new)
                .push((key.trim().to_ascii_lowercase(), value.trim().to_string()));
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::parse_section;

    #[test]
    fn sections_are_read_by_name_with_comments_and_spaces() {
        let text = "# keys\n[default]\naws_access_key_id = A\naws_secret_access_key=B\n\n\
                    [profile farm]\nregion = eu-west-1\n[other]\n; none\n";
        assert_eq!(
            parse_section(text, "default").unwrap(),
            [
                ("aws_access_key_id".to_string(), "A".to_string()),
                ("aws_secret_access_key".to_string(), "B".to_string())
            ]
        );
        assert_eq!(
            parse_section(text, "profile farm").unwrap(),
            [("region".to_string(), "eu-west-1".to_string())]
        );
        assert_eq!(parse_section(text, "other").unwrap(), []);
        assert_eq!(parse_section(text, "missing"), None);
    }
}
