//! The column grid narrows the linear search without losing any point below the surface.

use ori_eval::march::{COLUMN_CELL, ColumnDir, Columns, occupied_volume};

const N: usize = 256;
const EMPTY: u8 = 255;

/// A deterministic relief: blobs of varied heights, thin spikes, and empty space between.
fn relief() -> Vec<u8> {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut depth = vec![EMPTY; N * N];
    for _ in 0..40 {
        let (cx, cy) = ((next() % N as u64) as i64, (next() % N as u64) as i64);
        let r = 3 + (next() % 30) as i64;
        let base = (next() % 200) as i64;
        for y in (cy - r).max(0)..(cy + r).min(N as i64) {
            for x in (cx - r).max(0)..(cx + r).min(N as i64) {
                let d2 = (x - cx).pow(2) + (y - cy).pow(2);
                if d2 <= r * r {
                    let code = (base + d2 * 50 / (r * r)).min(254) as u8;
                    let t = &mut depth[y as usize * N + x as usize];
                    *t = (*t).min(code);
                }
            }
        }
    }
    // Single-texel spikes near the viewer.
    for _ in 0..60 {
        let i = (next() % (N * N) as u64) as usize;
        depth[i] = (next() % 20) as u8;
    }
    depth
}

/// The part of `o + z d` inside `[lo, hi]`, narrowing `span` (as the runtime's clip).
fn clip(o: f32, d: f32, lo: f32, hi: f32, span: &mut (f32, f32)) -> bool {
    if d == 0.0 {
        return o >= lo && o <= hi && span.0 < span.1;
    }
    let (a, b) = ((lo - o) / d, (hi - o) / d);
    span.0 = span.0.max(a.min(b));
    span.1 = span.1.min(a.max(b));
    span.0 < span.1
}

#[test]
fn every_point_below_the_surface_is_inside_the_narrowed_segment() {
    let depth = relief();
    let columns = Columns::new(&depth, N);
    assert_eq!(columns.cells(), N as u32 / COLUMN_CELL);
    let b = occupied_volume(&depth, N);
    let code = |x: f32, y: f32| -> u8 {
        if x >= 0.0 && y >= 0.0 && x < N as f32 && y < N as f32 {
            depth[y as usize * N + x as usize]
        } else {
            EMPTY
        }
    };
    let mut state = 7u64;
    let mut uniform = move |lo: f32, hi: f32| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((state >> 40) as f32 / (1u64 << 24) as f32)
    };
    let (mut rays, mut narrowed, mut shortened) = (0, 0, 0.0f64);
    for i in 0..3000 {
        // Every few rays an axis-aligned or vertical one.
        let (dx, dy) = match i % 10 {
            0 => (0.0, uniform(-2.0, 2.0)),
            1 => (uniform(-2.0, 2.0), 0.0),
            2 => (0.0, 0.0),
            _ => (uniform(-2.0, 2.0), uniform(-2.0, 2.0)),
        };
        let (ox, oy) = (uniform(-100.0, 356.0), uniform(-100.0, 356.0));
        let mut span = (b[4], b[5]);
        if !(clip(ox, dx, b[0], b[1], &mut span) && clip(oy, dy, b[2], b[3], &mut span)) {
            continue;
        }
        rays += 1;
        let found = columns.narrow(ox, oy, &ColumnDir::new(dx, dy), span);
        // Dense samples over the whole span.
        let samples = 20_000;
        for s in 0..=samples {
            let z = span.0 + (span.1 - span.0) * s as f32 / samples as f32;
            let c = code(ox + z * dx, oy + z * dy);
            if c != EMPTY && z >= f32::from(c) {
                let (start, end) = found.unwrap_or_else(|| {
                    panic!("ray {i}: below the surface at z = {z}, but no segment")
                });
                assert!(
                    z >= start - 1e-3 && z <= end + 1e-3,
                    "ray {i}: below the surface at z = {z}, outside [{start}, {end}]"
                );
            }
        }
        if let Some((start, end)) = found {
            narrowed += 1;
            assert!(span.0 <= start && start < end && end <= span.1);
            // The search starts above the surface or over empty (or at the span's own start).
            let c = code(ox + start * dx, oy + start * dy);
            assert!(
                start == span.0 || c == EMPTY || start < f32::from(c),
                "ray {i}: starts below the surface"
            );
            shortened += f64::from((end - start) / (span.1 - span.0));
        }
    }
    assert!(
        rays > 1000 && narrowed > 800,
        "{rays} rays, {narrowed} narrowed"
    );
    // The point of it: the searched segments are shorter.
    let mean = shortened / f64::from(narrowed);
    eprintln!("{rays} rays, {narrowed} narrowed to {mean:.2} of their length on average");
    assert!(
        mean < 0.9,
        "segments keep {mean:.2} of their length on average"
    );
}

#[test]
fn an_empty_map_has_no_columns() {
    let depth = vec![EMPTY; 64 * 64];
    let columns = Columns::new(&depth, 64);
    assert!(columns.tops().iter().all(|&t| t == EMPTY));
    assert_eq!(
        columns.narrow(3.0, 3.0, &ColumnDir::new(0.5, 0.25), (0.0, 254.0)),
        None
    );
}
