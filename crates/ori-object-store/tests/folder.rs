//! The store on a folder (`file://`), and the URL checks every scheme shares. The S3 store is
//! tested end to end against a real server in `tests/object_store_cache.rs`.

use std::time::Duration;

use ori_graph::{ContentHash, Namespace, RemoteError, RemoteStore};
use ori_object_store::{ObjectStoreRemote, check_url};

#[test]
fn a_folder_store_keeps_blobs_and_entries_apart_and_bounds_what_it_reads() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("shared cache");
    let url = format!("file://{}", root.display()).replace(' ', "%20");
    // A missing folder (an unmounted share) is an error, never made on the local disk.
    let e = ObjectStoreRemote::open(&url, Duration::from_secs(5))
        .err()
        .expect("a missing folder is refused");
    assert!(e.contains("is not a folder"), "{e}");
    assert!(!root.exists());
    std::fs::create_dir(&root).unwrap();
    let store = ObjectStoreRemote::open(&url, Duration::from_secs(5)).unwrap();
    assert_eq!(store.describe(), url);

    let blob = b"relief maps".to_vec();
    let hash = ContentHash(*blake3::hash(&blob).as_bytes());
    assert_eq!(store.get(Namespace::Cas, &hash, 1 << 20), Ok(None));
    assert_eq!(store.contains(Namespace::Cas, &hash), Ok(false));
    store.put(Namespace::Cas, &hash, &blob).unwrap();
    store.put(Namespace::Ac, &hash, b"entry").unwrap();
    assert_eq!(store.contains(Namespace::Cas, &hash), Ok(true));
    assert_eq!(
        store.get(Namespace::Cas, &hash, 1 << 20),
        Ok(Some(blob.clone()))
    );
    assert_eq!(
        store.get(Namespace::Ac, &hash, 1 << 20),
        Ok(Some(b"entry".to_vec()))
    );
    // The protocol's layout, so the folder can also be served over HTTP.
    let hex = hash.to_hex();
    assert!(root.join("cas").join(hex.as_str()).is_file());
    assert!(root.join("ac").join(hex.as_str()).is_file());
    // A longer object than the caller accepts is refused, not read.
    assert!(matches!(
        store.get(Namespace::Cas, &hash, blob.len() as u64 - 1),
        Err(RemoteError::Invalid(_))
    ));
    // Replacing keeps the last bytes.
    store.put(Namespace::Ac, &hash, b"newer").unwrap();
    assert_eq!(
        store.get(Namespace::Ac, &hash, 1 << 20),
        Ok(Some(b"newer".to_vec()))
    );
}

#[test]
fn urls_are_checked_without_repeating_credentials() {
    for good in [
        "s3://bucket",
        "s3://bucket/a/prefix",
        "gs://bucket/p",
        "az://container",
        "file:///srv/cache",
    ] {
        assert_eq!(check_url(good), Ok(()), "{good}");
    }
    for (bad, expected) in [
        ("s3://", "expected s3://bucket[/prefix]"),
        ("gs:///path", "expected gs://bucket[/prefix]"),
        ("az://", "expected az://container[/prefix]"),
        ("file://host/srv", "expected file:///absolute/path"),
        ("s3://bucket/p?versionId=1", "no query or fragment"),
        ("az://container?sig=SECRET", "no query or fragment"),
        ("s3://bucket/a//b", "not a valid object path"),
        ("ftp://host", "expected s3://"),
    ] {
        let e = check_url(bad).unwrap_err();
        assert!(e.contains(expected), "{bad}: {e}");
    }
    for url in ["s3://AKIA:hunter2@bucket", "az://container?sig=hunter2"] {
        let e = check_url(url).unwrap_err();
        assert!(e.contains("credentials come from the environment"), "{e}");
        assert!(!e.contains("hunter2"), "{e}");
    }
}
