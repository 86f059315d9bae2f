//! The headless renderer: adapter and device, the two pipelines, and one render call that
//! draws meshes and ORIs into offscreen targets and reads them back.

use bytemuck::{Pod, Zeroable};
use ori_mesh::Mesh;
use ori_package::Package;

use crate::camera::{Camera, to_gpu};
use crate::image::Image;
use crate::mesh::{GpuMesh, buffer};
use crate::ori::GpuOri;
use crate::pipelines::{Layouts, mesh_pipeline, ori_pipeline};
use crate::rays::{self, ImpostorRecord, Slot};
use crate::targets::Targets;
use crate::{Draw, OPTION5_BIAS_DIVISOR, Priority, RenderError};

/// How to set the renderer up.
#[derive(Clone, Debug)]
pub struct RendererOptions {
    /// Backends to look for an adapter on (default: every backend compiled in, narrowed by
    /// the `WGPU_BACKEND` environment variable).
    pub backends: wgpu::Backends,
    /// Decode BC textures on the CPU even when the adapter samples them (for tests of the
    /// fallback path).
    pub decode_on_cpu: bool,
}

impl Default for RendererOptions {
    fn default() -> Self {
        RendererOptions {
            backends: wgpu::Backends::all().with_env(),
            decode_on_cpu: false,
        }
    }
}

/// What the shaders share (`struct Globals`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Globals {
    world_to_clip: [[f32; 4]; 4],
    light: [f32; 4],
    view: [f32; 4],
    /// How clip depth follows distance from the viewer (for option 5's bias). Orthographic:
    /// x = clip depth per world unit. Perspective: y = a, z = b of `depth = a - b / dist`.
    depth: [f32; 4],
}

/// A headless wgpu device with the ORI and mesh pipelines.
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    compressed: bool,
    frame_layout: wgpu::BindGroupLayout,
    maps_layout: wgpu::BindGroupLayout,
    material_layout: wgpu::BindGroupLayout,
    ori_pipeline: wgpu::RenderPipeline,
    /// Option 5: biased depth, depth test only.
    ori_biased_pipeline: wgpu::RenderPipeline,
    /// The mesh: single-sided materials (back faces culled), double-sided ones.
    mesh_pipeline: wgpu::RenderPipeline,
    mesh_double_sided_pipeline: wgpu::RenderPipeline,
    max_size: u32,
}

impl Renderer {
    /// A renderer on whatever adapter exists (the default options).
    pub fn new() -> Result<Renderer, RenderError> {
        Renderer::with_options(&RendererOptions::default())
    }

    /// A renderer set up as `options` say.
    pub fn with_options(options: &RendererOptions) -> Result<Renderer, RenderError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = options.backends;
        let instance = wgpu::Instance::new(desc);
        let adapter = match pollster::block_on(
            instance.request_adapter(&wgpu::RequestAdapterOptions::default()),
        ) {
            Ok(adapter) => adapter,
            // Take whatever exists, fallback (software) adapters included.
            Err(first) => pollster::block_on(instance.enumerate_adapters(options.backends))
                .into_iter()
                .next()
                .ok_or_else(|| RenderError::NoAdapter(first.to_string()))?,
        };
        let info = adapter.get_info();
        let compressed = !options.decode_on_cpu
            && adapter
                .features()
                .contains(wgpu::Features::TEXTURE_COMPRESSION_BC);
        if !compressed {
            log::info!(
                "ori-render: {} cannot sample BC textures{}; decoding them on the CPU",
                info.name,
                if options.decode_on_cpu {
                    " (or was asked not to)"
                } else {
                    ""
                }
            );
        }
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("ori-render"),
            required_features: if compressed {
                wgpu::Features::TEXTURE_COMPRESSION_BC
            } else {
                wgpu::Features::empty()
            },
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| RenderError::Device(e.to_string()))?;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let layouts = Layouts::new(&device);
        let ori_biased_pipeline = ori_pipeline(&device, &layouts, Priority::BiasedDepth);
        let ori_pipeline = ori_pipeline(&device, &layouts, Priority::ClosestDirection);
        let mesh_double_sided_pipeline = mesh_pipeline(&device, &layouts, true);
        let mesh_pipeline = mesh_pipeline(&device, &layouts, false);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(RenderError::Gpu(e.to_string()));
        }
        Ok(Renderer {
            device,
            queue,
            info,
            compressed,
            frame_layout: layouts.frame,
            maps_layout: layouts.maps,
            material_layout: layouts.material,
            ori_pipeline,
            ori_biased_pipeline,
            mesh_pipeline,
            mesh_double_sided_pipeline,
            max_size: limits.max_texture_dimension_2d,
        })
    }

    /// The adapter in use: its name, backend, device type (`Cpu` for a software driver such
    /// as lavapipe), driver.
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// One line naming the adapter: `"name (backend, device type, driver)"`.
    pub fn adapter_summary(&self) -> String {
        let i = &self.info;
        format!(
            "{} ({:?}, {:?}, {} {})",
            i.name, i.backend, i.device_type, i.driver, i.driver_info
        )
    }

    /// Whether packages' BC textures are sampled compressed (else decoded on the CPU).
    pub fn compressed_textures(&self) -> bool {
        self.compressed
    }

    /// The wgpu device (for callers that draw more around the ORIs).
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The wgpu queue.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// Upload a package's maps (see [`GpuOri`] for the formats) and its selection table.
    pub fn load_package(&self, package: &Package) -> Result<GpuOri, RenderError> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let ori = GpuOri::new(
            &self.device,
            &self.queue,
            &self.maps_layout,
            package,
            self.compressed,
        );
        let error = pollster::block_on(scope.pop());
        match (ori, error) {
            (Err(e), _) => Err(e),
            (Ok(_), Some(e)) => Err(RenderError::Gpu(e.to_string())),
            (Ok(ori), None) => Ok(ori),
        }
    }

    /// Upload a mesh: positions, normals, UVs, vertex colours, materials (base-colour factor
    /// and texture, alpha test).
    pub fn load_mesh(&self, mesh: &Mesh) -> Result<GpuMesh, RenderError> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = GpuMesh::new(&self.device, &self.queue, &self.material_layout, mesh);
        let error = pollster::block_on(scope.pop());
        match (out, error) {
            (Err(e), _) => Err(e),
            (Ok(_), Some(e)) => Err(RenderError::Gpu(e.to_string())),
            (Ok(m), None) => Ok(m),
        }
    }

    /// The ORI alone, with the impostors its selection table gives for the camera's view
    /// direction.
    pub fn render_ori(
        &self,
        ori: &GpuOri,
        camera: &Camera,
        width: u32,
        height: u32,
    ) -> Result<Image, RenderError> {
        self.render(&[Draw::Ori(ori)], camera, width, height)
    }

    /// The mesh alone.
    pub fn render_mesh(
        &self,
        mesh: &GpuMesh,
        camera: &Camera,
        width: u32,
        height: u32,
    ) -> Result<Image, RenderError> {
        self.render(&[Draw::Mesh(mesh)], camera, width, height)
    }

    /// Draw `draws` in order into one `width x height` image (one depth buffer: they
    /// composite by depth) and read it back.
    pub fn render(
        &self,
        draws: &[Draw<'_>],
        camera: &Camera,
        width: u32,
        height: u32,
    ) -> Result<Image, RenderError> {
        if !camera.is_valid() {
            return Err(RenderError::Camera(format!("{camera:?}")));
        }
        if !(1..=self.max_size).contains(&width) || !(1..=self.max_size).contains(&height) {
            return Err(RenderError::Size {
                width,
                height,
                max: self.max_size,
            });
        }
        let plan = plan(draws, camera, width, height)?;
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let image = self.draw(&plan, camera, width, height);
        let error = pollster::block_on(scope.pop());
        match (image, error) {
            (Err(e), _) => Err(e),
            (Ok(_), Some(e)) => Err(RenderError::Gpu(e.to_string())),
            (Ok(image), None) => Ok(image),
        }
    }

    fn draw(
        &self,
        plan: &Plan<'_>,
        camera: &Camera,
        width: u32,
        height: u32,
    ) -> Result<Image, RenderError> {
        let device = &self.device;
        let light = camera.light();
        let view = match camera.projection {
            crate::Projection::Orthographic { .. } => {
                let d = camera.frame.d;
                [d[0] as f32, d[1] as f32, d[2] as f32, 0.0]
            }
            crate::Projection::Perspective { eye, .. } => {
                [eye[0] as f32, eye[1] as f32, eye[2] as f32, 1.0]
            }
        };
        let depth = match camera.projection {
            crate::Projection::Orthographic { near, far, .. } => {
                [(1.0 / (near - far)) as f32, 0.0, 0.0, 0.0]
            }
            crate::Projection::Perspective { near, far, .. } => [
                0.0,
                (far / (far - near)) as f32,
                (far * near / (far - near)) as f32,
                0.0,
            ],
        };
        let globals = Globals {
            world_to_clip: to_gpu(&camera.world_to_clip(width, height)),
            light: [light[0] as f32, light[1] as f32, light[2] as f32, 0.0],
            view,
            depth,
        };
        let globals = buffer(
            device,
            &self.queue,
            "globals",
            bytemuck::bytes_of(&globals),
            wgpu::BufferUsages::UNIFORM,
        );
        let records = buffer(
            device,
            &self.queue,
            "impostor records",
            bytemuck::cast_slice(&plan.records),
            wgpu::BufferUsages::STORAGE,
        );
        let frame = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame"),
            layout: &self.frame_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: globals.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: records.as_entire_binding(),
                },
            ],
        });
        let targets = Targets::new(device, width, height);
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = targets.pass(&mut encoder);
            for step in &plan.steps {
                match step {
                    Step::Mesh(mesh) => {
                        pass.set_bind_group(0, &frame, &[]);
                        pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                        pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                        for (material, range, double_sided) in &mesh.groups {
                            pass.set_pipeline(if *double_sided {
                                &self.mesh_double_sided_pipeline
                            } else {
                                &self.mesh_pipeline
                            });
                            pass.set_bind_group(1, material, &[]);
                            pass.draw_indexed(range.clone(), 0, 0..1);
                        }
                    }
                    Step::Ori {
                        ori,
                        records,
                        stencil,
                    } => {
                        if records.is_empty() {
                            continue;
                        }
                        // Option 5 draws in the same order with the depth test alone: the
                        // least biased depth wins, the earlier impostor on ties (LESS).
                        pass.set_pipeline(match ori.priority {
                            Priority::ClosestDirection => &self.ori_pipeline,
                            Priority::BiasedDepth => &self.ori_biased_pipeline,
                        });
                        pass.set_bind_group(0, &frame, &[]);
                        pass.set_bind_group(1, &ori.bind_group, &[]);
                        pass.set_stencil_reference(*stencil);
                        // One instance per impostor, closest direction first: instances
                        // rasterise in order, so the stencil's first writer is the closest.
                        pass.draw(0..36, records.clone());
                    }
                }
            }
        }
        let readback = targets.copy_out(device, &mut encoder);
        self.queue.submit([encoder.finish()]);
        readback.read(device, width, height)
    }
}

/// What one render draws, in order.
struct Plan<'a> {
    steps: Vec<Step<'a>>,
    records: Vec<ImpostorRecord>,
}

enum Step<'a> {
    Mesh(&'a GpuMesh),
    /// Instances `records` of the record buffer, with stencil reference `stencil`.
    Ori {
        ori: &'a GpuOri,
        records: std::ops::Range<u32>,
        stencil: u32,
    },
}

/// Each ORI's impostors for this camera, as records, and a stencil reference per ORI.
fn plan<'a>(
    draws: &[Draw<'a>],
    camera: &Camera,
    width: u32,
    height: u32,
) -> Result<Plan<'a>, RenderError> {
    let mut plan = Plan {
        steps: Vec::new(),
        records: Vec::new(),
    };
    let mut stencil = 0u32;
    for draw in draws {
        let (ori, subset) = match *draw {
            Draw::Mesh(mesh) => {
                plan.steps.push(Step::Mesh(mesh));
                continue;
            }
            Draw::Ori(ori) => {
                let (center, _) = ori.bounding_sphere();
                (ori, ori.selection(camera.view_direction(center)))
            }
            Draw::OriSubset(ori, subset) => (ori, subset),
        };
        stencil += 1;
        if stencil > 255 {
            return Err(RenderError::Scene(
                "more than 255 ORIs in one render (8-bit stencil)".into(),
            ));
        }
        let m = &ori.manifest;
        let bias = match ori.priority {
            Priority::ClosestDirection => 0.0,
            Priority::BiasedDepth => (ori.depth_range() / OPTION5_BIAS_DIVISOR) as f32,
        };
        let start = plan.records.len() as u32;
        for &i in subset {
            let imp = m.impostors.get(usize::from(i)).ok_or_else(|| {
                RenderError::Scene(format!(
                    "impostor {i} of a package with {}",
                    m.impostors.len()
                ))
            })?;
            let slot = Slot {
                layer: u32::from(i),
                index: i,
                column_cells: ori.column_cells,
            };
            if let Some(mut r) =
                rays::record(imp, m.resolution, camera, width, height, slot, &ori.march)
            {
                r.bias[0] = bias;
                plan.records.push(r);
            }
        }
        plan.steps.push(Step::Ori {
            ori,
            records: start..plan.records.len() as u32,
            stencil,
        });
    }
    Ok(plan)
}
