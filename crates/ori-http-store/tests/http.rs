//! The HTTP store against a hand-written server: the protocol's paths and the bearer token.

use ori_graph::{ContentHash, Namespace, RemoteStore};
use ori_http_store::HttpStore;

#[test]
fn the_http_store_sends_the_bearer_token_and_the_protocol_paths() {
    use std::io::{BufRead, BufReader, Write};
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap();
    let server = std::thread::spawn(move || {
        let (stream, _) = listener.accept().unwrap();
        let mut reader = BufReader::new(stream.try_clone().unwrap());
        let mut head = Vec::new();
        loop {
            let mut line = String::new();
            reader.read_line(&mut line).unwrap();
            if line.trim().is_empty() {
                break;
            }
            head.push(line.trim().to_string());
        }
        (&stream)
            .write_all(b"HTTP/1.1 404 Not Found\r\ncontent-length: 0\r\n\r\n")
            .unwrap();
        head
    });
    let store = HttpStore::new(
        &format!("http://{address}/base/"),
        Some("s3cret"),
        std::time::Duration::from_secs(5),
    );
    let key = ContentHash::of(b"key");
    assert_eq!(store.get(Namespace::Ac, &key, 100), Ok(None));
    let head = server.join().unwrap();
    assert_eq!(head[0], format!("GET /base/ac/{} HTTP/1.1", key.to_hex()));
    assert!(
        head.iter()
            .any(|h| h.eq_ignore_ascii_case("authorization: Bearer s3cret")),
        "{head:?}"
    );
}
