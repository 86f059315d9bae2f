//! Arbitrary bytes into `ori_package::read_any` (versions 1 and 2): never a panic, never a
//! large allocation (run with `-rss_limit_mb=512 -malloc_limit_mb=256`). A file that reads is
//! canonical: writing the package back gives the same bytes, which read to the same package.

#![no_main]

use libfuzzer_sys::fuzz_target;
use ori_package::AnyPackage;

fuzz_target!(|data: &[u8]| {
    match ori_package::read_any(data) {
        Ok(AnyPackage::Single(package)) => {
            let bytes = ori_package::write(&package.manifest, &package.textures)
                .expect("a package that reads must write");
            assert!(bytes == data, "write(read(x)) differs from x");
            let again = ori_package::read(&bytes).expect("a written package must read");
            assert_eq!(again, package);
        }
        Ok(AnyPackage::Hierarchy(h)) => {
            let nodes: Vec<Vec<u8>> = h
                .nodes
                .iter()
                .map(|p| ori_package::write(&p.manifest, &p.textures).expect("a node writes"))
                .collect();
            let bytes = ori_package::write_hierarchy(&h.manifest, &nodes)
                .expect("a hierarchy that reads must write");
            assert!(bytes == data, "write_hierarchy(read_hierarchy(x)) differs from x");
        }
        Err(_) => {}
    }
});
