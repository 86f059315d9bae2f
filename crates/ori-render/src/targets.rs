//! The offscreen targets of one render and their readback into an [`Image`].

use std::sync::mpsc;

use crate::RenderError;
use crate::image::{Image, SOURCE_NONE};

/// Colour target: shaded linear colour, encoded to sRGB by the hardware.
pub(crate) const COLOR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// The fragment's depth, kept for readback (the depth buffer itself cannot be copied).
pub(crate) const DEPTH_OUT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
/// Which draw made the pixel.
pub(crate) const SOURCE: wgpu::TextureFormat = wgpu::TextureFormat::R16Uint;
/// Depth test and the first-writer-wins stencil.
pub(crate) const DEPTH_STENCIL: wgpu::TextureFormat = wgpu::TextureFormat::Depth24PlusStencil8;
/// Value the depth readback target is cleared to (no fragment).
const NO_DEPTH: f64 = -1.0;

/// A colour attachment cleared to `clear` and stored.
fn attachment(view: &wgpu::TextureView, clear: wgpu::Color) -> wgpu::RenderPassColorAttachment<'_> {
    wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Clear(clear),
            store: wgpu::StoreOp::Store,
        },
    }
}

/// The offscreen targets of one render.
pub(crate) struct Targets {
    color: wgpu::Texture,
    color_view: wgpu::TextureView,
    depth: wgpu::Texture,
    depth_view: wgpu::TextureView,
    source: wgpu::Texture,
    source_view: wgpu::TextureView,
    depth_stencil_view: wgpu::TextureView,
}

impl Targets {
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Targets {
        let make = |format, usage| {
            let texture = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("target"),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            });
            let view = texture.create_view(&Default::default());
            (texture, view)
        };
        let out = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        let (color, color_view) = make(COLOR, out);
        let (depth, depth_view) = make(DEPTH_OUT, out);
        let (source, source_view) = make(SOURCE, out);
        let (_, depth_stencil_view) = make(DEPTH_STENCIL, wgpu::TextureUsages::RENDER_ATTACHMENT);
        Targets {
            color,
            color_view,
            depth,
            depth_view,
            source,
            source_view,
            depth_stencil_view,
        }
    }

    /// The render pass drawing into the targets, every one cleared.
    pub fn pass<'e>(&'e self, encoder: &'e mut wgpu::CommandEncoder) -> wgpu::RenderPass<'e> {
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("ori-render"),
            color_attachments: &[
                Some(attachment(&self.color_view, wgpu::Color::TRANSPARENT)),
                Some(attachment(
                    &self.depth_view,
                    wgpu::Color {
                        r: NO_DEPTH,
                        g: 0.0,
                        b: 0.0,
                        a: 0.0,
                    },
                )),
                Some(attachment(
                    &self.source_view,
                    wgpu::Color {
                        r: f64::from(SOURCE_NONE),
                        g: 0.0,
                        b: 0.0,
                        a: 0.0,
                    },
                )),
            ],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth_stencil_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(0),
                    store: wgpu::StoreOp::Discard,
                }),
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        })
    }

    /// Copy the three readable targets into mappable buffers.
    pub fn copy_out(&self, device: &wgpu::Device, encoder: &mut wgpu::CommandEncoder) -> Readback {
        let size = self.color.size();
        let mut copy = |texture: &wgpu::Texture, bytes_per_texel: u32| {
            let row =
                (size.width * bytes_per_texel).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
            let buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("readback"),
                size: u64::from(row) * u64::from(size.height),
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            });
            encoder.copy_texture_to_buffer(
                texture.as_image_copy(),
                wgpu::TexelCopyBufferInfo {
                    buffer: &buffer,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(row),
                        rows_per_image: Some(size.height),
                    },
                },
                size,
            );
            (buffer, row)
        };
        Readback {
            color: copy(&self.color, 4),
            depth: copy(&self.depth, 4),
            source: copy(&self.source, 2),
        }
    }
}

/// Mappable copies of the targets, with their padded row pitch.
pub(crate) struct Readback {
    color: (wgpu::Buffer, u32),
    depth: (wgpu::Buffer, u32),
    source: (wgpu::Buffer, u32),
}

impl Readback {
    pub fn read(
        self,
        device: &wgpu::Device,
        width: u32,
        height: u32,
    ) -> Result<Image, RenderError> {
        let (tx, rx) = mpsc::channel();
        for (buffer, _) in [&self.color, &self.depth, &self.source] {
            let tx = tx.clone();
            buffer.map_async(wgpu::MapMode::Read, .., move |r| {
                let _ = tx.send(r);
            });
        }
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        for _ in 0..3 {
            rx.recv()
                .map_err(|e| RenderError::Readback(e.to_string()))?
                .map_err(|e| RenderError::Readback(e.to_string()))?;
        }
        let rows =
            |(buffer, row): &(wgpu::Buffer, u32), texel: usize| -> Result<Vec<u8>, RenderError> {
                let view = buffer
                    .get_mapped_range(..)
                    .map_err(|e| RenderError::Readback(e.to_string()))?;
                let line = width as usize * texel;
                let mut out = Vec::with_capacity(line * height as usize);
                for y in 0..height as usize {
                    let start = y * *row as usize;
                    out.extend_from_slice(&view[start..start + line]);
                }
                Ok(out)
            };
        let mut rgba = rows(&self.color, 4)?;
        let depth_bytes = rows(&self.depth, 4)?;
        let source_bytes = rows(&self.source, 2)?;
        let source: Vec<u16> = source_bytes
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
            .collect();
        let depth: Vec<f32> = depth_bytes
            .chunks_exact(4)
            .zip(&source)
            .map(|(b, &s)| {
                if s == SOURCE_NONE {
                    f32::NAN
                } else {
                    f32::from_le_bytes([b[0], b[1], b[2], b[3]])
                }
            })
            .collect();
        for (px, &s) in rgba.chunks_exact_mut(4).zip(&source) {
            px[3] = if s == SOURCE_NONE { 0 } else { 255 };
        }
        Ok(Image {
            width,
            height,
            rgba,
            depth,
            source,
        })
    }
}
