//! Arbitrary bytes into `ori_package::read`: never a panic, never a large allocation (run
//! with `-rss_limit_mb=512 -malloc_limit_mb=256`). A file that reads is canonical: writing
//! the package back gives the same bytes, which read to the same package.

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(package) = ori_package::read(data) {
        let bytes = ori_package::write(&package.manifest, &package.textures)
            .expect("a package that reads must write");
        assert!(bytes == data, "write(read(x)) differs from x");
        let again = ori_package::read(&bytes).expect("a written package must read");
        assert_eq!(again, package);
    }
});
