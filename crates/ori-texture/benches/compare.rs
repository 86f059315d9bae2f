//! Our encoders against intel_tex_2 (ISPC kernels) and texpresso (a libsquish port), on real
//! textures, in one run: `cargo bench -p ori-texture --bench compare`.
//!
//! Every encoder runs single-threaded (ours inside a one-thread rayon pool); the time is the
//! encode alone, the median of several runs. Every output is decoded by our float decoder
//! (`ori_texture::decode`), so all codecs are measured under one decode model. Quality: RGB
//! PSNR for BC1 and PSNR for BC4 (the mean of per-image dB), and for BC5 the angle between the
//! normals rebuilt from the source and from the decoded x, y (mean, p99, max in degrees,
//! pooled over the set) beside the 8-bit quantisation floor.
//!
//! More images (the baked relief maps) plug in through [`add_extra_images`].

#[path = "../tests/common/mod.rs"]
mod common;

use std::time::{Duration, Instant};

use ori_texture::metrics::{
    AngularStats, normal_angular_error, normal_quantisation_floor, psnr_channel, psnr_rgb,
};
use ori_texture::{Quality, RgbaImage, decode_bc1, decode_bc4, decode_bc5};

/// An RGB texture (BC1).
struct Colour {
    name: String,
    image: RgbaImage,
}

/// One 8-bit channel (BC4).
struct Grey {
    name: String,
    values: Vec<u8>,
    width: u32,
    height: u32,
}

/// Normal x, y interleaved (BC5).
struct Normal {
    name: String,
    xy: Vec<u8>,
    width: u32,
    height: u32,
}

/// Albedo and its "not empty" mask (mask-aware BC1).
struct Masked {
    name: String,
    image: RgbaImage,
    mask: Vec<bool>,
}

/// The named images each comparison runs on.
#[derive(Default)]
struct ImageSets {
    colour: Vec<Colour>,
    grey: Vec<Grey>,
    normal: Vec<Normal>,
    masked: Vec<Masked>,
}

impl ImageSets {
    fn colour(&mut self, name: &str, image: &RgbaImage) {
        self.colour.push(Colour {
            name: name.into(),
            image: common::opaque(image),
        });
    }

    fn grey(&mut self, name: &str, image: &RgbaImage, channel: usize) {
        self.grey.push(Grey {
            name: name.into(),
            values: image.channel(channel),
            width: image.width(),
            height: image.height(),
        });
    }

    fn normal(&mut self, name: &str, image: &RgbaImage) {
        self.normal.push(Normal {
            name: name.into(),
            xy: image.red_green(),
            width: image.width(),
            height: image.height(),
        });
    }

    /// Albedo whose empty texels are those with alpha < 128.
    fn masked_by_alpha(&mut self, name: &str, image: &RgbaImage) {
        self.masked.push(Masked {
            name: name.into(),
            mask: image.data().chunks_exact(4).map(|t| t[3] >= 128).collect(),
            image: common::opaque(image),
        });
    }
}

/// Real textures only: the Avocado, DamagedHelmet and Duck textures, and the alpha-tested
/// leaves of GlassVaseFlowers for the mask.
fn real_images() -> ImageSets {
    let mut sets = ImageSets::default();
    let helmet = common::glb_images("gltf/DamagedHelmet/DamagedHelmet.glb");
    let flowers = common::glb_images("gltf/GlassVaseFlowers/GlassVaseFlowers.glb");
    let duck = common::glb_images("gltf/Duck/Duck.glb");

    sets.colour(
        "Avocado_baseColor",
        &common::png("gltf/Avocado/glTF/Avocado_baseColor.png"),
    );
    sets.colour("DamagedHelmet albedo", &helmet[0]);
    sets.colour("Duck", &duck[0]);

    // BC4: the red channel of each albedo above, and two maps real materials store as one
    // channel. (Avocado's roughness is left out: it is nearly constant, so every codec is
    // near-lossless on it and its dB would measure float rounding, not the encoder.)
    for c in &sets
        .colour
        .iter()
        .map(|c| (c.name.clone(), c.image.clone()))
        .collect::<Vec<_>>()
    {
        sets.grey(&format!("{} (R)", c.0), &c.1, 0);
    }
    sets.grey("DamagedHelmet roughness (G)", &helmet[1], 1);
    sets.grey("DamagedHelmet occlusion (R)", &helmet[3], 0);

    sets.normal(
        "Avocado_normal",
        &common::png("gltf/Avocado/glTF/Avocado_normal.png"),
    );
    sets.normal("DamagedHelmet normal", &helmet[4]);
    sets.normal("GlassVaseFlowers normal", &flowers[0]);

    sets.masked_by_alpha("GlassVaseFlowers leaves (alpha < 128 empty)", &flowers[1]);
    sets
}

/// Baked relief maps (depth, normal, albedo + empty mask from the bake stage) are added here
/// once `ori-bake` writes them, e.g. `sets.grey(name, &depth, 0)`,
/// `sets.normal(name, &normal)`, `sets.masked.push(Masked { .. })`.
fn add_extra_images(_sets: &mut ImageSets) {}

/// Median encode time over `runs` runs, and the output of the last.
fn timed(runs: usize, mut encode: impl FnMut() -> Vec<u8>) -> (Duration, Vec<u8>) {
    let mut times = Vec::with_capacity(runs);
    let mut out = Vec::new();
    for _ in 0..runs {
        let start = Instant::now();
        out = encode();
        times.push(start.elapsed());
    }
    times.sort();
    (times[runs / 2], out)
}

/// Quality and speed of one encoder over one image set.
struct Result {
    /// Mean of per-image dB, or mean angle in degrees.
    quality: f64,
    /// For BC5: pooled angular statistics.
    angles: Option<AngularStats>,
    mpix_per_s: f64,
}

fn mpix(pixels: usize, time: Duration) -> f64 {
    pixels as f64 / 1e6 / time.as_secs_f64()
}

/// Runs `encode` on every colour image; quality is the mean RGB PSNR (dB) with our decoder.
fn bench_bc1(images: &[Colour], runs: usize, encode: impl Fn(&RgbaImage) -> Vec<u8>) -> Result {
    let (mut total, mut pixels, mut psnr) = (Duration::ZERO, 0, 0.0);
    for c in images {
        let (t, blocks) = timed(runs, || encode(&c.image));
        let decoded = decode_bc1(&blocks, c.image.width(), c.image.height()).expect("blocks");
        psnr += psnr_rgb(&c.image, &decoded, None);
        total += t;
        pixels += c.image.data().len() / 4;
    }
    Result {
        quality: psnr / images.len() as f64,
        angles: None,
        mpix_per_s: mpix(pixels, total),
    }
}

fn bench_bc4(images: &[Grey], runs: usize, encode: impl Fn(&Grey) -> Vec<u8>) -> Result {
    let (mut total, mut pixels, mut psnr) = (Duration::ZERO, 0, 0.0);
    for g in images {
        let (t, blocks) = timed(runs, || encode(g));
        let decoded = decode_bc4(&blocks, g.width, g.height).expect("blocks");
        psnr += psnr_channel(&g.values, &decoded);
        total += t;
        pixels += g.values.len();
    }
    Result {
        quality: psnr / images.len() as f64,
        angles: None,
        mpix_per_s: mpix(pixels, total),
    }
}

fn bench_bc5(images: &[Normal], runs: usize, encode: impl Fn(&Normal) -> Vec<u8>) -> Result {
    let (mut total, mut pixels) = (Duration::ZERO, 0);
    let (mut reference, mut decoded) = (Vec::new(), Vec::new());
    for n in images {
        let (t, blocks) = timed(runs, || encode(n));
        decoded.extend(decode_bc5(&blocks, n.width, n.height).expect("blocks"));
        reference.extend_from_slice(&n.xy);
        total += t;
        pixels += n.xy.len() / 2;
    }
    let angles = normal_angular_error(&reference, &decoded);
    Result {
        quality: angles.mean,
        angles: Some(angles),
        mpix_per_s: mpix(pixels, total),
    }
}

fn texpresso_bc1(image: &RgbaImage) -> Vec<u8> {
    let (w, h) = (image.width() as usize, image.height() as usize);
    let mut out = vec![0u8; texpresso::Format::Bc1.compressed_size(w, h)];
    let params = texpresso::Params {
        algorithm: texpresso::Algorithm::ClusterFit,
        // We measure RGB PSNR, so the fit must weigh channels uniformly too.
        weights: texpresso::COLOUR_WEIGHTS_UNIFORM,
        weigh_colour_by_alpha: false,
    };
    texpresso::Format::Bc1.compress(image.data(), w, h, params, &mut out);
    out
}

/// texpresso's BC4 / BC5 take RGBA input: spread the channel(s) into R (and G).
fn texpresso_channels(format: texpresso::Format, rgba: &[u8], w: u32, h: u32) -> Vec<u8> {
    let (w, h) = (w as usize, h as usize);
    let mut out = vec![0u8; format.compressed_size(w, h)];
    format.compress(rgba, w, h, texpresso::Params::default(), &mut out);
    out
}

fn grey_to_rgba(values: &[u8]) -> Vec<u8> {
    values.iter().flat_map(|&v| [v, 0, 0, 255]).collect()
}

fn xy_to_rgba(xy: &[u8]) -> Vec<u8> {
    xy.chunks_exact(2)
        .flat_map(|p| [p[0], p[1], 0, 255])
        .collect()
}

fn main() {
    let started = Instant::now();
    let mut sets = real_images();
    add_extra_images(&mut sets);
    let pool = &rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("one-thread pool");
    let ours_bc1 = |q: Quality| {
        move |img: &RgbaImage| pool.install(|| ori_texture::encode_bc1(img, None, q).unwrap())
    };

    println!(
        "ori-texture compare: single-threaded encode time (median), quality under our float decoder"
    );
    println!();
    println!("Image sets:");
    let list = |names: Vec<&str>| names.join(", ");
    println!(
        "  BC1 albedo : {}",
        list(sets.colour.iter().map(|c| c.name.as_str()).collect())
    );
    println!(
        "  BC4 single : {}",
        list(sets.grey.iter().map(|c| c.name.as_str()).collect())
    );
    println!(
        "  BC5 normal : {}",
        list(sets.normal.iter().map(|c| c.name.as_str()).collect())
    );
    println!(
        "  BC1 masked : {}",
        list(sets.masked.iter().map(|c| c.name.as_str()).collect())
    );
    println!();

    // BC1
    let intel_bc1 = bench_bc1(&sets.colour, 5, |img| {
        intel_tex_2::bc1::compress_blocks(&intel_tex_2::RgbaSurface {
            data: img.data(),
            width: img.width(),
            height: img.height(),
            stride: img.width() * 4,
        })
    });
    let texpresso_cf = bench_bc1(&sets.colour, 3, texpresso_bc1);
    let bc1_fast = bench_bc1(&sets.colour, 5, ours_bc1(Quality::Fast));
    let bc1_high = bench_bc1(&sets.colour, 3, ours_bc1(Quality::High));

    // BC4
    let intel_bc4 = bench_bc4(&sets.grey, 5, |g| {
        intel_tex_2::bc4::compress_blocks(&intel_tex_2::RSurface {
            data: &g.values,
            width: g.width,
            height: g.height,
            stride: g.width,
        })
    });
    let texpresso_bc4 = bench_bc4(&sets.grey, 3, |g| {
        texpresso_channels(
            texpresso::Format::Bc4,
            &grey_to_rgba(&g.values),
            g.width,
            g.height,
        )
    });
    let ours_bc4 = |q: Quality| {
        move |g: &Grey| {
            pool.install(|| ori_texture::encode_bc4(&g.values, g.width, g.height, q).unwrap())
        }
    };
    let bc4_fast = bench_bc4(&sets.grey, 5, ours_bc4(Quality::Fast));
    let bc4_high = bench_bc4(&sets.grey, 5, ours_bc4(Quality::High));

    // BC5
    let intel_bc5 = bench_bc5(&sets.normal, 5, |n| {
        intel_tex_2::bc5::compress_blocks(&intel_tex_2::RgSurface {
            data: &n.xy,
            width: n.width,
            height: n.height,
            stride: n.width * 2,
        })
    });
    let texpresso_bc5 = bench_bc5(&sets.normal, 3, |n| {
        texpresso_channels(
            texpresso::Format::Bc5,
            &xy_to_rgba(&n.xy),
            n.width,
            n.height,
        )
    });
    let ours_bc5 = |q: Quality| {
        move |n: &Normal| {
            pool.install(|| ori_texture::encode_bc5(&n.xy, n.width, n.height, q).unwrap())
        }
    };
    let bc5_fast = bench_bc5(&sets.normal, 5, ours_bc5(Quality::Fast));
    let bc5_high = bench_bc5(&sets.normal, 5, ours_bc5(Quality::High));
    let all_xy: Vec<u8> = sets
        .normal
        .iter()
        .flat_map(|n| n.xy.iter().copied())
        .collect();
    let floor = normal_quantisation_floor(&all_xy);

    // Mask-aware BC1: PSNR over non-empty texels, with and without the mask.
    let mut masked_rows = Vec::new();
    for m in &sets.masked {
        let mut row = vec![m.name.clone()];
        for q in [Quality::Fast, Quality::High] {
            for mask in [None, Some(m.mask.as_slice())] {
                let blocks = pool.install(|| ori_texture::encode_bc1(&m.image, mask, q).unwrap());
                let decoded = decode_bc1(&blocks, m.image.width(), m.image.height()).unwrap();
                row.push(format!(
                    "{:.3}",
                    psnr_rgb(&m.image, &decoded, Some(&m.mask))
                ));
            }
        }
        masked_rows.push(row);
    }

    let mut table = Table::default();
    let ratio = |a: f64, b: f64| a / b;
    table.row(
        "BC1",
        "fast",
        "albedo",
        "RGB PSNR dB",
        &bc1_fast,
        &intel_bc1,
        &texpresso_cf,
        format!(
            ">= intel + 0.2 dB ({:+.3}), >= 50 MPix/s",
            bc1_fast.quality - intel_bc1.quality - 0.2
        ),
        bc1_fast.quality >= intel_bc1.quality + 0.2 && bc1_fast.mpix_per_s >= 50.0,
    );
    table.row(
        "BC1",
        "high",
        "albedo",
        "RGB PSNR dB",
        &bc1_high,
        &intel_bc1,
        &texpresso_cf,
        format!(
            ">= texpresso CF - 0.05 dB ({:+.3}), >= 10x its speed ({:.1}x)",
            bc1_high.quality - texpresso_cf.quality + 0.05,
            ratio(bc1_high.mpix_per_s, texpresso_cf.mpix_per_s)
        ),
        bc1_high.quality >= texpresso_cf.quality - 0.05
            && bc1_high.mpix_per_s >= 10.0 * texpresso_cf.mpix_per_s,
    );
    for (level, r) in [("fast", &bc4_fast), ("high", &bc4_high)] {
        table.row(
            "BC4",
            level,
            "single channel",
            "PSNR dB",
            r,
            &intel_bc4,
            &texpresso_bc4,
            format!(
                ">= intel + 0.5 dB ({:+.3}), >= 20 MPix/s",
                r.quality - intel_bc4.quality - 0.5
            ),
            r.quality >= intel_bc4.quality + 0.5 && r.mpix_per_s >= 20.0,
        );
    }
    for (level, r) in [("fast", &bc5_fast), ("high", &bc5_high)] {
        table.row(
            "BC5",
            level,
            "normals",
            "mean angle deg",
            r,
            &intel_bc5,
            &texpresso_bc5,
            format!(
                "<= 0.9x intel ({:.3}x), >= 10 MPix/s",
                r.quality / intel_bc5.quality
            ),
            r.quality <= 0.9 * intel_bc5.quality && r.mpix_per_s >= 10.0,
        );
    }
    table.print();

    println!();
    println!("BC5 angular error, degrees (mean / p99 / max, pooled over the normal maps):");
    let show = |name: &str, a: &AngularStats| {
        println!(
            "  {name:<22} {:>7.4} / {:>7.3} / {:>7.3}",
            a.mean, a.p99, a.max
        );
    };
    show("8-bit floor", &floor);
    show("intel_tex_2", intel_bc5.angles.as_ref().unwrap());
    show("texpresso", texpresso_bc5.angles.as_ref().unwrap());
    show("ours fast", bc5_fast.angles.as_ref().unwrap());
    show("ours high", bc5_high.angles.as_ref().unwrap());

    println!();
    println!("Mask-aware BC1, RGB PSNR dB over non-empty texels:");
    println!(
        "  {:<46} {:>10} {:>10} {:>10} {:>10}  target: masked > unmasked",
        "image", "fast", "fast+mask", "high", "high+mask"
    );
    for row in &masked_rows {
        let met = row[2].parse::<f64>().unwrap() > row[1].parse::<f64>().unwrap()
            && row[4].parse::<f64>().unwrap() > row[3].parse::<f64>().unwrap();
        println!(
            "  {:<46} {:>10} {:>10} {:>10} {:>10}  {}",
            row[0],
            row[1],
            row[2],
            row[3],
            row[4],
            if met { "met" } else { "MISSED" }
        );
    }
    println!();
    println!("total bench time {:.1} s", started.elapsed().as_secs_f64());
}

/// The comparison table.
#[derive(Default)]
struct Table {
    rows: Vec<[String; 12]>,
}

impl Table {
    #[allow(clippy::too_many_arguments)]
    fn row(
        &mut self,
        codec: &str,
        level: &str,
        set: &str,
        metric: &str,
        ours: &Result,
        intel: &Result,
        texpresso: &Result,
        target: String,
        met: bool,
    ) {
        let q = |r: &Result| format!("{:.3}", r.quality);
        let s = |r: &Result| format!("{:.1}", r.mpix_per_s);
        self.rows.push([
            codec.into(),
            level.into(),
            set.into(),
            metric.into(),
            q(ours),
            q(intel),
            q(texpresso),
            s(ours),
            s(intel),
            s(texpresso),
            target,
            (if met { "met" } else { "MISSED" }).into(),
        ]);
    }

    fn print(&self) {
        let header = [
            "codec",
            "level",
            "images",
            "metric",
            "ours",
            "intel",
            "texpresso",
            "ours MPix/s",
            "intel MPix/s",
            "texp MPix/s",
            "target (margin)",
            "",
        ];
        let mut widths = header.map(str::len);
        for row in &self.rows {
            for (w, cell) in widths.iter_mut().zip(row) {
                *w = (*w).max(cell.len());
            }
        }
        let line = |cells: &[String]| {
            let parts: Vec<String> = cells
                .iter()
                .zip(widths)
                .map(|(c, w)| format!("{c:<w$}"))
                .collect();
            println!("{}", parts.join(" | "));
        };
        line(&header.map(String::from));
        line(&widths.map(|w| "-".repeat(w)));
        for row in &self.rows {
            line(row);
        }
    }
}
