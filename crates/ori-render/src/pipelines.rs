//! The bind group layouts and the render pipelines: `shaders/ori.wgsl` (impostors, option 3
//! with a first-writer-wins stencil, option 5 with the biased depth and the depth test) and
//! `shaders/mesh.wgsl` (reference meshes).

use crate::Priority;
use crate::mesh::Vertex;
use crate::targets::{COLOR, DEPTH_OUT, DEPTH_STENCIL, SOURCE};

const ORI_SHADER: &str = include_str!("../../../shaders/ori.wgsl");
const MESH_SHADER: &str = include_str!("../../../shaders/mesh.wgsl");

/// The bind group layouts.
pub(crate) struct Layouts {
    /// Group 0 of both pipelines: globals and the impostor records.
    pub frame: wgpu::BindGroupLayout,
    /// Group 1 of the ORI pipeline: depth, normal, albedo arrays.
    pub maps: wgpu::BindGroupLayout,
    /// Group 1 of the mesh pipeline: material uniform, texture, sampler.
    pub material: wgpu::BindGroupLayout,
}

impl Layouts {
    pub fn new(device: &wgpu::Device) -> Layouts {
        let both = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let frame = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("frame"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: both,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: both,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: true },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let map = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2Array,
                multisampled: false,
            },
            count: None,
        };
        let columns = wgpu::BindGroupLayoutEntry {
            binding: 3,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: true },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let maps = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("ori maps"),
            entries: &[map(0), map(1), map(2), columns],
        });
        let material = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("material"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        Layouts {
            frame,
            maps,
            material,
        }
    }
}

/// The three colour targets every pipeline writes.
fn color_targets() -> [Option<wgpu::ColorTargetState>; 3] {
    [COLOR, DEPTH_OUT, SOURCE].map(|format| {
        Some(wgpu::ColorTargetState {
            format,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        })
    })
}

/// The ORI pipeline of one priority rule: option 3 with the first-writer-wins stencil,
/// option 5 with the depth test alone (the fragment writes the biased depth).
pub(crate) fn ori_pipeline(
    device: &wgpu::Device,
    layouts: &Layouts,
    priority: Priority,
) -> wgpu::RenderPipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("ori.wgsl"),
        source: wgpu::ShaderSource::Wgsl(ORI_SHADER.into()),
    });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("ori"),
        bind_group_layouts: &[Some(&layouts.frame), Some(&layouts.maps)],
        immediate_size: 0,
    });
    // First writer wins: pass where the stencil is not this ORI's reference yet, and claim
    // the pixel whether the depth test passes or not (a closer impostor hidden behind other
    // geometry still hides the farther ones).
    let first_writer = wgpu::StencilFaceState {
        compare: wgpu::CompareFunction::NotEqual,
        fail_op: wgpu::StencilOperation::Keep,
        depth_fail_op: wgpu::StencilOperation::Replace,
        pass_op: wgpu::StencilOperation::Replace,
    };
    let stencil = match priority {
        Priority::ClosestDirection => wgpu::StencilState {
            front: first_writer,
            back: first_writer,
            read_mask: 0xff,
            write_mask: 0xff,
        },
        // Option 5 leaves the stencil alone: the least biased depth wins through the depth
        // test (LESS, so the earlier impostor keeps a tie).
        Priority::BiasedDepth => wgpu::StencilState::default(),
    };
    let label = match priority {
        Priority::ClosestDirection => "ori",
        Priority::BiasedDepth => "ori (biased depth)",
    };
    let targets = color_targets();
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            front_face: wgpu::FrontFace::Ccw,
            // The box's back faces: one fragment per pixel whose ray meets the box, even
            // with the eye inside it.
            cull_mode: Some(wgpu::Face::Front),
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH_STENCIL,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil,
            bias: wgpu::DepthBiasState::default(),
        }),
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// The reference mesh's pipeline: `double_sided` materials draw both windings; single-sided
/// ones cull back faces, as the CPU rasterizer does (`ori_raster::faces_away`).
pub(crate) fn mesh_pipeline(
    device: &wgpu::Device,
    layouts: &Layouts,
    double_sided: bool,
) -> wgpu::RenderPipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("mesh.wgsl"),
        source: wgpu::ShaderSource::Wgsl(MESH_SHADER.into()),
    });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("mesh"),
        bind_group_layouts: &[Some(&layouts.frame), Some(&layouts.material)],
        immediate_size: 0,
    });
    let targets = color_targets();
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("mesh"),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[Some(Vertex::LAYOUT)],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            // Counter-clockwise seen from the front, as the meshes' windings.
            front_face: wgpu::FrontFace::Ccw,
            cull_mode: (!double_sided).then_some(wgpu::Face::Back),
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH_STENCIL,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        }),
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}
