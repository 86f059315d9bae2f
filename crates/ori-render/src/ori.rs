//! A package on the GPU: its maps as three texture arrays (one layer per impostor), its
//! manifest, and the 320-direction selection table.

use ori_package::{Manifest, Package, TextureFormat};
use ori_texture::{Ktx2, VkFormat};

use crate::{MarchParams, Priority, RenderError};

/// An ORI ready to draw: made by [`crate::Renderer::load_package`].
///
/// Textures, by what the adapter can sample: depth as `R8Unorm` (or `Bc4RUnorm` when the
/// package stores BC4), normal x, y as `Bc5RgUnorm`, albedo as `Bc1RgbaUnormSrgb`; without
/// `TEXTURE_COMPRESSION_BC` the BC maps are decoded on the CPU (`ori_texture`'s D3D10
/// decoders) to `R8Unorm`, `Rg8Unorm` and `Rgba8UnormSrgb`. Only level 0 is uploaded: the
/// runtime rule reads the nearest texel of level 0.
pub struct GpuOri {
    pub(crate) manifest: Manifest,
    /// The 320 evaluation directions, in the selection table's order.
    directions: Vec<[f64; 3]>,
    pub(crate) march: MarchParams,
    pub(crate) priority: Priority,
    /// World length that option 5's depth is measured in; `None`: the bounding sphere's
    /// diameter.
    depth_range: Option<f64>,
    compressed: bool,
    /// Cells per side of each map's column grid (the tops are in the bind group).
    pub(crate) column_cells: u32,
    pub(crate) bind_group: wgpu::BindGroup,
    _textures: [wgpu::Texture; 3],
    _columns: wgpu::Buffer,
}

/// The three maps of every impostor, as uploaded.
enum Map {
    Depth,
    Normal,
    Albedo,
}

impl GpuOri {
    pub(crate) fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        layout: &wgpu::BindGroupLayout,
        package: &Package,
        compressed: bool,
    ) -> Result<GpuOri, RenderError> {
        let manifest = &package.manifest;
        let n = manifest.resolution;
        let layers = u32::try_from(manifest.impostors.len())
            .map_err(|_| RenderError::Package("too many impostors".into()))?;
        if layers == 0 || package.textures.len() != manifest.impostors.len() {
            return Err(RenderError::Package(
                "the package's textures do not match its impostors".into(),
            ));
        }
        let directions = ori_views::evaluation_directions();
        if manifest.selection.entries.len() != directions.len() {
            return Err(RenderError::Package(format!(
                "the selection table has {} entries, not {}",
                manifest.selection.entries.len(),
                directions.len()
            )));
        }
        let mut textures = Vec::new();
        for map in [Map::Depth, Map::Normal, Map::Albedo] {
            textures.push(upload(device, queue, package, &map, n, layers, compressed)?);
        }
        let views: Vec<wgpu::TextureView> = textures
            .iter()
            .map(|t| {
                t.create_view(&wgpu::TextureViewDescriptor {
                    dimension: Some(wgpu::TextureViewDimension::D2Array),
                    ..Default::default()
                })
            })
            .collect();
        let (column_cells, tops) = column_tops(package, n)?;
        let columns = crate::mesh::buffer(
            device,
            queue,
            "ori column tops",
            bytemuck::cast_slice(&tops),
            wgpu::BufferUsages::STORAGE,
        );
        let mut entries: Vec<wgpu::BindGroupEntry> = [0, 1, 2]
            .map(|i| wgpu::BindGroupEntry {
                binding: i,
                resource: wgpu::BindingResource::TextureView(&views[i as usize]),
            })
            .into();
        entries.push(wgpu::BindGroupEntry {
            binding: 3,
            resource: columns.as_entire_binding(),
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("ori maps"),
            layout,
            entries: &entries,
        });
        let [depth, normal, albedo]: [wgpu::Texture; 3] = textures.try_into().expect("three maps");
        Ok(GpuOri {
            manifest: manifest.clone(),
            directions,
            march: MarchParams::from_manifest(manifest),
            priority: Priority::default(),
            depth_range: None,
            compressed,
            column_cells,
            bind_group,
            _textures: [depth, normal, albedo],
            _columns: columns,
        })
    }

    /// The package's manifest.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// Whether the BC maps were uploaded compressed (else decoded on the CPU).
    pub fn compressed(&self) -> bool {
        self.compressed
    }

    /// The search parameters the impostors are drawn with: the package's own (its
    /// `params.select`) or the defaults.
    pub fn march(&self) -> MarchParams {
        self.march
    }

    /// Draw with other search parameters.
    pub fn set_march(&mut self, march: MarchParams) {
        self.march = march;
    }

    /// The priority rule between this ORI's impostors (default
    /// [`Priority::ClosestDirection`]).
    pub fn priority(&self) -> Priority {
        self.priority
    }

    /// Draw with another priority rule.
    pub fn set_priority(&mut self, priority: Priority) {
        self.priority = priority;
    }

    /// The world length that is one unit of depth for [`Priority::BiasedDepth`] (its bias is
    /// `cos / 32` of it): the one set with [`GpuOri::set_depth_range`], else the bounding
    /// sphere's diameter. The evaluator (`ori_eval`) measures depth in the evaluation view's
    /// range, the object's extent along the view direction (`OrthoView::near - far`): set
    /// that to reproduce an evaluation view exactly.
    pub fn depth_range(&self) -> f64 {
        self.depth_range
            .unwrap_or(2.0 * self.manifest.bounding_sphere.radius)
    }

    /// Set the unit of depth of [`Priority::BiasedDepth`] (a positive, finite world
    /// length), or `None` for the bounding sphere's diameter.
    pub fn set_depth_range(&mut self, range: Option<f64>) {
        self.depth_range = range.filter(|r| r.is_finite() && *r > 0.0);
    }

    /// The 320 evaluation directions of the selection table, in its order
    /// (`ori_views::evaluation_directions`).
    pub fn directions(&self) -> &[[f64; 3]] {
        &self.directions
    }

    /// Index of the evaluation direction nearest to `w` (towards the viewer): the largest dot
    /// product, the lowest index on ties (as `ori_select::Selection::lookup`).
    pub fn direction_index(&self, w: [f64; 3]) -> usize {
        let mut best = (0, f64::NEG_INFINITY);
        for (i, d) in self.directions.iter().enumerate() {
            let dot = d[0] * w[0] + d[1] * w[1] + d[2] * w[2];
            if dot > best.1 {
                best = (i, dot);
            }
        }
        best.0
    }

    /// The impostors to draw for view direction `w` (towards the viewer), closest direction
    /// first: the selection table's entry of the nearest evaluation direction.
    pub fn selection(&self, w: [f64; 3]) -> &[u16] {
        &self.manifest.selection.entries[self.direction_index(w)].impostors
    }

    /// Centre and radius of the package's bounding sphere.
    pub fn bounding_sphere(&self) -> ([f64; 3], f64) {
        let s = &self.manifest.bounding_sphere;
        (s.center, s.radius)
    }
}

/// One map of every impostor as a texture array.
fn upload(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    package: &Package,
    map: &Map,
    n: u32,
    layers: u32,
    compressed: bool,
) -> Result<wgpu::Texture, RenderError> {
    let depth_bc4 = package.manifest.depth_format == TextureFormat::Bc4;
    let (gpu_format, decoded) = match (map, compressed) {
        (Map::Depth, true) if depth_bc4 => (wgpu::TextureFormat::Bc4RUnorm, false),
        (Map::Depth, false) if depth_bc4 => (wgpu::TextureFormat::R8Unorm, true),
        (Map::Depth, _) => (wgpu::TextureFormat::R8Unorm, false),
        (Map::Normal, true) => (wgpu::TextureFormat::Bc5RgUnorm, false),
        (Map::Normal, false) => (wgpu::TextureFormat::Rg8Unorm, true),
        (Map::Albedo, true) => (wgpu::TextureFormat::Bc1RgbaUnormSrgb, false),
        (Map::Albedo, false) => (wgpu::TextureFormat::Rgba8UnormSrgb, true),
    };
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some(match map {
            Map::Depth => "ori depth",
            Map::Normal => "ori normal",
            Map::Albedo => "ori albedo",
        }),
        size: wgpu::Extent3d {
            width: n,
            height: n,
            depth_or_array_layers: layers,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: gpu_format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    for layer in 0..layers {
        let i = layer as usize;
        let bytes = match map {
            Map::Depth => &package.textures[i].depth,
            Map::Normal => &package.textures[i].normal,
            Map::Albedo => &package.textures[i].albedo,
        };
        let ktx = Ktx2::from_bytes(bytes)
            .map_err(|e| RenderError::Package(format!("impostor {i}: {e}")))?;
        if ktx.width() != n || ktx.height() != n || ktx.levels().is_empty() {
            return Err(RenderError::Package(format!(
                "impostor {i}: a map is not {n} x {n}"
            )));
        }
        let level = &ktx.levels()[0];
        let texels = if decoded {
            ori_texture::decode::to_bytes(ktx.format(), level, n)
                .map_err(|e| RenderError::Package(e.to_string()))?
        } else {
            level.clone()
        };
        let (edge, block_bytes) = match (decoded, ktx.format()) {
            (true, VkFormat::Bc1RgbSrgb | VkFormat::Bc1RgbUnorm) => (1, 4),
            (true, VkFormat::Bc5Unorm) => (1, 2),
            (true, _) => (1, 1),
            (false, f) => f.block(),
        };
        let blocks = n.div_ceil(edge);
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: 0,
                origin: wgpu::Origin3d {
                    x: 0,
                    y: 0,
                    z: layer,
                },
                aspect: wgpu::TextureAspect::All,
            },
            &texels,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(blocks * block_bytes as u32),
                rows_per_image: Some(blocks),
            },
            wgpu::Extent3d {
                width: n,
                height: n,
                depth_or_array_layers: 1,
            },
        );
    }
    Ok(texture)
}

/// Edge in texels of a column-grid cell (`ori_eval::march::COLUMN_CELL`; the shader's
/// `COLUMN_CELL`).
pub const COLUMN_CELL: u32 = 8;

/// Every map's column grid (`ori_eval::march::Columns`, which a test holds this equal to):
/// cells per side, and per layer, row by row, the least depth code of each cell's non-empty
/// texels (255 when none), one `u32` per cell. Computed from the depth the shader reads (a
/// BC4 map decoded on the CPU; should the adapter's BC4 decoding differ by a code, the
/// columns still start one code above each top).
pub fn column_tops(package: &Package, n: u32) -> Result<(u32, Vec<u32>), RenderError> {
    let cells = n.div_ceil(COLUMN_CELL) as usize;
    let (n, t) = (n as usize, COLUMN_CELL as usize);
    let mut tops = vec![255u32; cells * cells * package.textures.len()];
    for (i, textures) in package.textures.iter().enumerate() {
        let ktx = Ktx2::from_bytes(&textures.depth)
            .map_err(|e| RenderError::Package(format!("impostor {i}: {e}")))?;
        let level = ktx
            .levels()
            .first()
            .ok_or_else(|| RenderError::Package(format!("impostor {i}: no depth level")))?;
        let depth = ori_texture::decode::to_bytes(ktx.format(), level, n as u32)
            .map_err(|e| RenderError::Package(format!("impostor {i}: {e}")))?;
        if depth.len() != n * n {
            return Err(RenderError::Package(format!(
                "impostor {i}: the depth map is not {n} x {n}"
            )));
        }
        let grid = &mut tops[i * cells * cells..(i + 1) * cells * cells];
        for (y, row) in depth.chunks_exact(n).enumerate() {
            for (x, &code) in row.iter().enumerate() {
                let top = &mut grid[(y / t) * cells + x / t];
                *top = (*top).min(u32::from(code));
            }
        }
    }
    Ok((cells as u32, tops))
}
