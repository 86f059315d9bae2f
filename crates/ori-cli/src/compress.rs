//! `ori compress-texture` (also `cargo xtask compress-texture`): one PNG to one KTX2 file (BC1 sRGB albedo, BC4 or BC5),
//! with an optional report of speed and quality.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::ValueEnum;
use ori_texture::metrics::{
    normal_angular_error, normal_quantisation_floor, psnr_channel, psnr_rgb,
};
use ori_texture::{Ktx2, Quality, RgbaImage, VkFormat};

#[derive(clap::Args)]
pub struct Args {
    /// Block format: bc1 (RGB albedo, stored as sRGB), bc4 (the first channel: red, or the
    /// grey value), bc5 (red and green: normal x, y).
    #[arg(long, value_enum)]
    format: Format,
    /// Encoder effort.
    #[arg(long, value_enum, default_value_t = Level::High)]
    quality: Level,
    /// BC1 only: texels with alpha < 128 are empty, so the endpoints fit the others only.
    #[arg(long)]
    alpha_mask: bool,
    /// Print the size, encode time, speed and quality figures.
    #[arg(long)]
    report: bool,
    /// Input PNG (8 or 16 bits, grey or colour, any size).
    input: PathBuf,
    /// Output KTX2 file; written whole or not at all.
    output: PathBuf,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Format {
    Bc1,
    Bc4,
    Bc5,
}

#[derive(Clone, Copy, ValueEnum)]
enum Level {
    Fast,
    High,
}

/// Exit status 1: a file could not be read, decoded or written. 2: the options do not fit
/// together (clap reports malformed command lines with 2 as well).
pub fn run(args: Args) -> ExitCode {
    if args.alpha_mask && args.format != Format::Bc1 {
        eprintln!("error: --alpha-mask applies to --format bc1 only");
        return ExitCode::from(2);
    }
    let image = match ori_texture::load_png_file(&args.input) {
        Ok(image) => image,
        Err(e) => {
            eprintln!("error: {}: {e}", args.input.display());
            return ExitCode::from(1);
        }
    };
    let quality = match args.quality {
        Level::Fast => Quality::Fast,
        Level::High => Quality::High,
    };
    let (w, h) = (image.width(), image.height());
    let mask: Option<Vec<bool>> = args
        .alpha_mask
        .then(|| image.data().chunks_exact(4).map(|t| t[3] >= 128).collect());

    let start = Instant::now();
    let encoded = match args.format {
        Format::Bc1 => ori_texture::encode_bc1(&image, mask.as_deref(), quality),
        Format::Bc4 => ori_texture::encode_bc4(&image.channel(0), w, h, quality),
        Format::Bc5 => ori_texture::encode_bc5(&image.red_green(), w, h, quality),
    };
    let seconds = start.elapsed().as_secs_f64();
    let vk_format = match args.format {
        Format::Bc1 => VkFormat::Bc1RgbSrgb,
        Format::Bc4 => VkFormat::Bc4Unorm,
        Format::Bc5 => VkFormat::Bc5Unorm,
    };
    let file = encoded.and_then(|blocks| Ktx2::new(vk_format, w, h, vec![blocks]));
    let file = match file {
        Ok(file) => file,
        Err(e) => {
            eprintln!("error: {}: {e}", args.input.display());
            return ExitCode::from(1);
        }
    };
    let bytes = file.to_bytes();
    if let Err(e) = ori_graph::write_atomic(&args.output, &bytes) {
        eprintln!("error: {}: {e}", args.output.display());
        return ExitCode::from(1);
    }
    if args.report {
        print_report(&args, &image, mask.as_deref(), &file, bytes.len(), seconds);
    }
    ExitCode::SUCCESS
}

fn print_report(
    args: &Args,
    image: &RgbaImage,
    mask: Option<&[bool]>,
    file: &Ktx2,
    file_bytes: usize,
    seconds: f64,
) {
    let (w, h) = (image.width(), image.height());
    let blocks = &file.levels()[0];
    println!("input     {}", args.input.display());
    println!(
        "format    {:?} (vkFormat {})",
        file.format(),
        file.format().value()
    );
    println!(
        "size      {w} x {h} texels, {} bytes of blocks, {file_bytes} bytes of KTX2",
        blocks.len()
    );
    println!(
        "encode    {:.1} ms, {:.1} MPix/s ({} threads)",
        seconds * 1e3,
        f64::from(w) * f64::from(h) / 1e6 / seconds,
        rayon::current_num_threads()
    );
    match args.format {
        Format::Bc1 => {
            let decoded = ori_texture::decode_bc1(blocks, w, h).expect("our own blocks");
            println!(
                "quality   RGB PSNR {:.3} dB",
                psnr_rgb(image, &decoded, None)
            );
            if let Some(mask) = mask {
                let kept = mask.iter().filter(|&&m| m).count();
                println!(
                    "          over the {kept} non-empty texels {:.3} dB",
                    psnr_rgb(image, &decoded, Some(mask))
                );
            }
        }
        Format::Bc4 => {
            let decoded = ori_texture::decode_bc4(blocks, w, h).expect("our own blocks");
            println!(
                "quality   PSNR {:.3} dB",
                psnr_channel(&image.channel(0), &decoded)
            );
        }
        Format::Bc5 => {
            let xy = image.red_green();
            let decoded = ori_texture::decode_bc5(blocks, w, h).expect("our own blocks");
            let err = normal_angular_error(&xy, &decoded);
            let floor = normal_quantisation_floor(&xy);
            println!(
                "quality   normal angle error mean {:.4}, p99 {:.3}, max {:.3} degrees",
                err.mean, err.p99, err.max
            );
            println!(
                "          8-bit floor        mean {:.4}, p99 {:.3}, max {:.3} degrees",
                floor.mean, floor.p99, floor.max
            );
        }
    }
}
