//! A reference mesh on the GPU: interleaved vertices, triangles grouped by material, one bind
//! group per material (factor, alpha test, base-colour texture and sampler).

use bytemuck::{Pod, Zeroable};
use ori_mesh::{AlphaMode, Mesh, Wrap};

use crate::RenderError;

/// One vertex as `shaders/mesh.wgsl` reads it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct Vertex {
    position: [f32; 3],
    normal: [f32; 3],
    uv: [f32; 2],
    color: [f32; 4],
}

impl Vertex {
    pub(crate) const LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<Vertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &wgpu::vertex_attr_array![
            0 => Float32x3, 1 => Float32x3, 2 => Float32x2, 3 => Float32x4
        ],
    };
}

/// `struct Material` of `shaders/mesh.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct MaterialUniform {
    factor: [f32; 4],
    alpha: [f32; 4],
}

/// A mesh ready to draw: made by [`crate::Renderer::load_mesh`].
pub struct GpuMesh {
    pub(crate) vertices: wgpu::Buffer,
    pub(crate) indices: wgpu::Buffer,
    /// Per material with triangles: its bind group, its index range, and whether it is
    /// double-sided (single-sided materials are drawn with back faces culled).
    pub(crate) groups: Vec<(wgpu::BindGroup, std::ops::Range<u32>, bool)>,
    triangles: usize,
}

impl GpuMesh {
    pub(crate) fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        layout: &wgpu::BindGroupLayout,
        mesh: &Mesh,
    ) -> Result<GpuMesh, RenderError> {
        let bad = |m: String| Err(RenderError::Mesh(m));
        let nv = mesh.positions.len();
        if mesh.normals.len() != nv
            || mesh.uvs.as_ref().is_some_and(|t| t.len() != nv)
            || mesh.colors.as_ref().is_some_and(|c| c.len() != nv)
            || mesh.triangle_materials.len() != mesh.triangles.len()
            || u32::try_from(nv).is_err()
        {
            return bad("vertex or triangle attributes of different lengths".into());
        }
        if mesh.triangles.iter().flatten().any(|&i| i as usize >= nv) {
            return bad("a triangle index is out of range".into());
        }
        if mesh
            .triangle_materials
            .iter()
            .any(|&m| m as usize >= mesh.materials.len())
        {
            return bad("a triangle's material is out of range".into());
        }
        let vertices: Vec<Vertex> = (0..nv)
            .map(|i| Vertex {
                position: mesh.positions[i],
                normal: mesh.normals[i],
                uv: mesh.uvs.as_ref().map_or([0.0; 2], |t| t[i]),
                color: mesh.colors.as_ref().map_or([1.0; 4], |c| c[i]),
            })
            .collect();
        // Triangles grouped by material, in material order (a stable counting sort).
        let mut indices = Vec::with_capacity(3 * mesh.triangles.len());
        let mut ranges = Vec::new();
        for m in 0..mesh.materials.len() {
            let start = indices.len() as u32;
            for (t, &tm) in mesh.triangles.iter().zip(&mesh.triangle_materials) {
                if tm as usize == m {
                    indices.extend_from_slice(t);
                }
            }
            let end = indices.len() as u32;
            if end > start {
                ranges.push((m, start..end));
            }
        }
        let vertex_buffer = buffer(
            device,
            queue,
            "mesh vertices",
            bytemuck::cast_slice(&vertices),
            wgpu::BufferUsages::VERTEX,
        );
        let index_buffer = buffer(
            device,
            queue,
            "mesh indices",
            bytemuck::cast_slice(&indices),
            wgpu::BufferUsages::INDEX,
        );
        let mut groups = Vec::new();
        for (m, range) in ranges {
            let bind_group = material_bind_group(device, queue, layout, mesh, m)?;
            groups.push((bind_group, range, mesh.materials[m].double_sided));
        }
        Ok(GpuMesh {
            vertices: vertex_buffer,
            indices: index_buffer,
            groups,
            triangles: mesh.triangles.len(),
        })
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles
    }
}

/// A buffer holding `bytes` (at least 4 bytes, so that an empty mesh still has a buffer).
pub(crate) fn buffer(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    label: &str,
    bytes: &[u8],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    let size = (bytes.len() as u64).max(16).next_multiple_of(4);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: usage | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    if !bytes.is_empty() {
        let mut padded = bytes.to_vec();
        padded.resize(bytes.len().next_multiple_of(4), 0);
        queue.write_buffer(&buffer, 0, &padded);
    }
    buffer
}

fn address(wrap: Wrap) -> wgpu::AddressMode {
    match wrap {
        Wrap::Repeat => wgpu::AddressMode::Repeat,
        Wrap::MirroredRepeat => wgpu::AddressMode::MirrorRepeat,
        Wrap::ClampToEdge => wgpu::AddressMode::ClampToEdge,
    }
}

fn material_bind_group(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    layout: &wgpu::BindGroupLayout,
    mesh: &Mesh,
    m: usize,
) -> Result<wgpu::BindGroup, RenderError> {
    let material = &mesh.materials[m];
    let texture = match material.base_color_texture {
        Some(t) => Some(mesh.textures.get(t as usize).ok_or_else(|| {
            RenderError::Mesh(format!("material {m}: texture {t} is out of range"))
        })?),
        None => None,
    };
    let uniform = MaterialUniform {
        factor: material.base_color_factor,
        alpha: [
            material.alpha_cutoff,
            if material.alpha_mode == AlphaMode::Mask {
                1.0
            } else {
                0.0
            },
            if texture.is_some() { 1.0 } else { 0.0 },
            0.0,
        ],
    };
    let uniform = buffer(
        device,
        queue,
        "material",
        bytemuck::bytes_of(&uniform),
        wgpu::BufferUsages::UNIFORM,
    );
    let (width, height, rgba) = match texture {
        Some(t) => {
            let n = t.width as usize * t.height as usize * 4;
            if t.width == 0 || t.height == 0 || t.rgba8.len() != n {
                return Err(RenderError::Mesh(format!(
                    "texture {}: {} bytes for {} x {} texels",
                    t.name,
                    t.rgba8.len(),
                    t.width,
                    t.height
                )));
            }
            (t.width, t.height, t.rgba8.as_slice())
        }
        None => (1, 1, &[255u8; 4][..]),
    };
    let gpu_texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("base colour"),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8UnormSrgb,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    queue.write_texture(
        gpu_texture.as_image_copy(),
        rgba,
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(4 * width),
            rows_per_image: Some(height),
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
    );
    let view = gpu_texture.create_view(&Default::default());
    let (wrap_s, wrap_t, nearest) = texture.map_or((Wrap::Repeat, Wrap::Repeat, false), |t| {
        (t.wrap_s, t.wrap_t, t.nearest)
    });
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("base colour"),
        address_mode_u: address(wrap_s),
        address_mode_v: address(wrap_t),
        mag_filter: if nearest {
            wgpu::FilterMode::Nearest
        } else {
            wgpu::FilterMode::Linear
        },
        min_filter: wgpu::FilterMode::Linear,
        ..Default::default()
    });
    Ok(device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("material"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: uniform.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(&view),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::Sampler(&sampler),
            },
        ],
    }))
}
