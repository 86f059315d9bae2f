//! The conformance data of docs/conformance, run by the two implementations of the runtime
//! rule this project has: the CPU evaluator (exact) and the wgpu shader (within the tolerance
//! docs/RUNTIME.md states for GPU arithmetic).

use std::path::PathBuf;

use ori_conformance::{
    CASES_DIR, Case, Directions, Expected, RUNTIME_DOC, differences, documented_version, row_pixel,
};
use ori_package::TextureFormat;
use ori_render::{Camera, Draw, Renderer};

fn root() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

fn documented() -> u32 {
    let doc = root().join(RUNTIME_DOC);
    let text = std::fs::read_to_string(&doc).unwrap_or_else(|e| panic!("{}: {e}", doc.display()));
    documented_version(&text).expect("docs/RUNTIME.md states `Runtime version: N`")
}

fn cases() -> Vec<(Case, Expected)> {
    let cases = Case::all(&root().join(CASES_DIR)).unwrap();
    assert!(cases.len() >= 2, "the conformance cases are missing");
    cases
        .into_iter()
        .map(|c| {
            let expected = c.expected().unwrap();
            (c, expected)
        })
        .collect()
}

#[test]
fn the_cpu_evaluator_gives_the_recorded_results_of_the_documented_version() {
    let version = documented();
    for (case, expected) in cases() {
        let name = case.name();
        let loaded = case.load().unwrap();
        let found = loaded.compute(version).unwrap();
        let diff = differences(&expected, &found, 20);
        assert!(
            diff.is_empty(),
            "{name}: the runtime rule's results changed:\n  {}\nIf the change is meant, \
             document it in {RUNTIME_DOC}, raise its `Runtime version` and run `cargo xtask \
             conformance --write`.",
            diff.join("\n  ")
        );
        // The pipeline selects on the depth it ships (BC4 decoded): the package's own table
        // is the one the rule recomputes from the package.
        assert_eq!(
            loaded.package.manifest.selection.entries, found.table,
            "{name}"
        );
    }
}

#[test]
fn the_recorded_direction_sets_are_those_of_ori_views() {
    let recorded = Directions::recorded(&root().join(CASES_DIR)).unwrap();
    assert_eq!(recorded, Directions::compute());
}

#[test]
fn the_cases_cover_both_depth_formats_and_several_subset_sizes() {
    let mut formats = Vec::new();
    for (case, expected) in cases() {
        formats.push(case.load().unwrap().package.manifest.depth_format);
        let sizes: std::collections::BTreeSet<usize> =
            expected.table.iter().map(|e| e.impostors.len()).collect();
        assert!(sizes.len() >= 3, "{}: subset sizes {sizes:?}", case.name());
        let empty = expected
            .views
            .iter()
            .flat_map(|v| &v.impostors)
            .all(|i| i.mask.iter().all(|row| row.bytes().all(|b| b == b'0')));
        assert!(!empty, "{}: every mask is empty", case.name());
    }
    assert!(formats.contains(&TextureFormat::R8));
    assert!(formats.contains(&TextureFormat::Bc4));
}

/// Pixels where the wgpu renderer's coverage of each candidate impostor differs from the
/// recorded masks, and the pixels compared, over every view of the cases whose depth format
/// `depth_formats` accepts.
fn gpu_disagreement(
    renderer: &Renderer,
    depth_formats: impl Fn(TextureFormat) -> bool,
) -> (usize, usize) {
    let (mut differ, mut compared) = (0, 0);
    for (case, expected) in cases() {
        let loaded = case.load().unwrap();
        if !depth_formats(loaded.package.manifest.depth_format) {
            continue;
        }
        let mut ori = renderer.load_package(&loaded.package).unwrap();
        let params = loaded.select_params().unwrap();
        ori.set_march(ori_render::MarchParams {
            linear_steps: params.linear_steps,
            binary_steps: params.binary_steps,
            wall_threshold: params.wall_threshold as f32,
        });
        let s0 = expected.s0;
        for view in &expected.views {
            let camera = Camera::from_view(&view.ortho_view(s0));
            for imp in &view.impostors {
                let index = [imp.impostor as u16];
                let image = renderer
                    .render(&[Draw::OriSubset(&ori, &index)], &camera, s0, s0)
                    .unwrap();
                let mut here = 0;
                for y in 0..s0 as usize {
                    for x in 0..s0 as usize {
                        let want = row_pixel(&imp.mask, x, y).expect("a pixel of the mask");
                        here += usize::from(image.covered(y * s0 as usize + x) != want);
                        compared += 1;
                    }
                }
                differ += here;
            }
        }
    }
    (differ, compared)
}

fn renderer(decode_on_cpu: bool) -> Renderer {
    // No adapter is a failure, never a skip: CI installs Mesa's lavapipe.
    let options = ori_render::RendererOptions {
        decode_on_cpu,
        ..Default::default()
    };
    Renderer::with_options(&options)
        .unwrap_or_else(|e| panic!("no GPU adapter (CI needs mesa-vulkan-drivers): {e}"))
}

#[test]
fn the_wgpu_renderer_draws_the_recorded_masks_from_exact_depth_codes() {
    // BC4 decoded on the CPU as RUNTIME.md specifies: every depth code exact.
    let renderer = renderer(true);
    let (differ, compared) = gpu_disagreement(&renderer, |_| true);
    eprintln!(
        "{}: {differ} of {compared} pixels differ",
        renderer.adapter_summary()
    );
    assert_eq!(differ, 0, "{differ} of {compared} pixels differ");
}

#[test]
fn hardware_bc4_sampling_stays_within_the_stated_tolerance() {
    let renderer = renderer(false);
    if !renderer.compressed_textures() {
        eprintln!(
            "{}: BC textures decoded on the CPU",
            renderer.adapter_summary()
        );
    }
    let bc4 = |f: TextureFormat| f == TextureFormat::Bc4;
    let (differ, compared) = gpu_disagreement(&renderer, |f| !bc4(f));
    assert_eq!(
        differ, 0,
        "exact depth: {differ} of {compared} pixels differ"
    );
    let (differ, compared) = gpu_disagreement(&renderer, bc4);
    eprintln!(
        "{}: BC4 sampled by the device: {differ} of {compared} pixels differ",
        renderer.adapter_summary()
    );
    // RUNTIME.md, "Depth codes": a device's BC4 decoder may round interpolated codes
    // differently; at most 1 pixel in 100 may change.
    assert!(
        differ * 100 <= compared,
        "{differ} of {compared} pixels differ"
    );
}
