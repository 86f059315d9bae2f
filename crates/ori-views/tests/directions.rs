//! The generated direction sets: sizes, unit length, symmetry, spacing and nesting.

use ori_views::{axis_directions, evaluation_directions, icosahedron_directions};

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    ori_math::angle_between(a, b).to_degrees()
}

fn nearest(set: &[[f64; 3]], p: [f64; 3]) -> (usize, f64) {
    set.iter()
        .enumerate()
        .map(|(i, &d)| (i, angle_deg(d, p)))
        .fold(
            (usize::MAX, f64::INFINITY),
            |a, b| if b.1 < a.1 { b } else { a },
        )
}

/// Unit length, centrally symmetric (each direction's opposite is in the set), so the sum is 0.
fn check_set(set: &[[f64; 3]]) {
    let mut sum = [0.0; 3];
    for &d in set {
        assert!((dot(d, d) - 1.0).abs() < 1e-15, "{d:?} is not unit length");
        let opposite = d.map(|x| -x);
        assert!(nearest(set, opposite).1 < 1e-6, "{d:?} has no opposite");
        for k in 0..3 {
            sum[k] += d[k];
        }
    }
    assert!(sum.iter().all(|s| s.abs() < 1e-12), "sum {sum:?}");
}

#[test]
fn icosahedron_sets_have_the_expected_sizes_and_are_symmetric_unit_sets() {
    for (level, n) in [(0, 20), (1, 80), (2, 320), (3, 1280), (4, 5120)] {
        let set = icosahedron_directions(level);
        assert_eq!(set.len(), n);
        if n <= 1280 {
            check_set(&set);
        }
    }
    check_set(&axis_directions());
    assert_eq!(evaluation_directions(), icosahedron_directions(2));
}

#[test]
fn the_twenty_are_the_icosahedron_face_centroids() {
    let twenty = icosahedron_directions(0);
    // Adjacent face normals of an icosahedron are 180 - 138.19 (dihedral) = 41.81 degrees
    // apart, and every face has exactly three neighbours.
    for &d in &twenty {
        let mut angles: Vec<f64> = twenty.iter().map(|&e| angle_deg(d, e)).collect();
        angles.sort_by(f64::total_cmp);
        assert!(angles[0] < 1e-6);
        for a in &angles[1..4] {
            assert!((a - 41.810_314_9).abs() < 1e-6, "{angles:?}");
        }
        assert!(angles[4] > 70.0);
    }
    // The farthest any direction is from the set: the icosahedron's vertices, 37.38 degrees
    // from the three surrounding centroids (the paper's "approximately 37 degrees").
    let phi = 0.5 * (1.0 + 5f64.sqrt());
    let len = (1.0 + phi * phi).sqrt();
    let vertex = [0.0, 1.0 / len, phi / len];
    let worst = icosahedron_directions(4)
        .iter()
        .chain([&vertex])
        .map(|&p| nearest(&twenty, p).1)
        .fold(0.0, f64::max);
    assert!((worst - 37.377_368).abs() < 1e-5, "covering radius {worst}");
}

#[test]
fn subdivisions_nest() {
    for level in 0..3 {
        let parents = icosahedron_directions(level);
        let children = icosahedron_directions(level + 1);
        for (j, &child) in children.iter().enumerate() {
            assert_eq!(
                nearest(&parents, child).0,
                j / 4,
                "level {level}, child {j}"
            );
        }
    }
}

#[test]
fn spacing_halves_with_each_level() {
    // The covering radius (largest angle from a probe direction to its nearest set member)
    // shrinks by about two per level.
    let probes = icosahedron_directions(5);
    let radius = |level| {
        let set = icosahedron_directions(level);
        probes
            .iter()
            .map(|&p| nearest(&set, p).1)
            .fold(0.0, f64::max)
    };
    let radii = [0, 1, 2].map(radius);
    for w in radii.windows(2) {
        assert!(w[1] < 0.6 * w[0] && w[1] > 0.4 * w[0], "{radii:?}");
    }
}

#[test]
fn held_out_directions_are_fixed_unit_and_away_from_the_table() {
    use ori_views::{HELD_OUT_RANDOM, held_out_directions};
    let held = held_out_directions(ori_views::DEFAULT_HELD_OUT_SEED);
    assert_eq!(held.len(), 1280 + HELD_OUT_RANDOM);
    assert_eq!(held[..1280], ori_views::icosahedron_directions(3)[..]);
    for d in &held {
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        assert!((len - 1.0).abs() < 1e-12, "{d:?}");
    }
    // No held-out direction is a table direction.
    for t in ori_views::evaluation_directions() {
        for d in &held {
            assert!(d != &t, "{d:?}");
        }
    }
    // Uniform on the sphere: the mean is near the centre, each hemisphere holds about half.
    let random = &held[1280..];
    for axis in 0..3 {
        let mean: f64 = random.iter().map(|d| d[axis]).sum::<f64>() / random.len() as f64;
        assert!(mean.abs() < 0.04, "axis {axis}: mean {mean}");
        let up = random.iter().filter(|d| d[axis] > 0.0).count();
        assert!(
            (900..1100).contains(&up),
            "axis {axis}: {up} of {}",
            random.len()
        );
    }
    // The same bits on every machine and run; another seed gives other directions.
    let bits = |dirs: &[[f64; 3]]| {
        let mut h = blake3::Hasher::new();
        for d in dirs {
            for c in d {
                h.update(&c.to_bits().to_le_bytes());
            }
        }
        h.finalize().to_hex().to_string()
    };
    assert_eq!(bits(&held), bits(&held_out_directions(1)));
    assert_eq!(bits(&held[1280..]), HELD_OUT_SEED_1_BITS);
    assert_ne!(held_out_directions(2)[1280..], held[1280..]);
}

/// blake3 of the random held-out directions of seed 1 (each coordinate's bits, little-endian).
const HELD_OUT_SEED_1_BITS: &str =
    "26fe33d22608b803e9e999320bcb329c9aff66637e76481aa40a5bac6a264bfa";
