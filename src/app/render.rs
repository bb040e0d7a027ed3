//! The wgpu renderer. One code path for the editor viewport and for offscreen
//! rendering: both render a [`SceneData`] into a [`RenderTarget`] (multisampled
//! colour + depth, resolved into an `Rgba8Unorm` texture holding sRGB-encoded
//! bytes). The viewport then blits that texture into egui's pass; offscreen
//! callers read it back with [`read_rgba`].

use std::num::NonZeroU64;

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use super::camera::OrbitCamera;
use super::scene::{Glyph, LineSegment, Overlay, SceneData, Vertex};
use super::settings::{DisplayMode, DisplaySettings, Pattern, RemeshDisplay, Shading};

pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
pub const SAMPLE_COUNT: u32 = 4;

/// A shader's source: shaders/common.wgsl (the uniform block and shared helpers), then the file.
macro_rules! shader {
    ($file:literal) => {
        concat!(
            include_str!("../../shaders/common.wgsl"),
            "\n",
            include_str!(concat!("../../shaders/", $file))
        )
    };
}

pub const MESH_WGSL: &str = shader!("mesh.wgsl");
pub const OVERLAY_WGSL: &str = shader!("overlay.wgsl");
pub const BLIT_WGSL: &str = shader!("blit.wgsl");
pub const LIC_WGSL: &str = shader!("lic.wgsl");
/// Format of the LIC G-buffer (screen directions, noise, depth) and of the LIC result.
pub const LIC_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// Mirrors `struct Uniforms` in shaders/mesh.wgsl and shaders/overlay.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Uniforms {
    pub view_proj: [[f32; 4]; 4],
    pub camera_pos: [f32; 4],
    pub light_dir: [f32; 4],
    pub base_color: [f32; 4],
    pub wire_color: [f32; 4],
    pub pattern_color: [f32; 4],
    pub params: [f32; 4],
    pub params2: [f32; 4],
    pub viewport: [f32; 4],
    pub modes: [u32; 4],
    pub flags: [u32; 4],
}

/// Colour + depth targets of one size, plus the single-sample targets of the
/// screen-space LIC (G-buffer, its depth, the LIC result) and their bind groups.
/// Made by [`Renderer::create_target`]; recreate only when the size changes.
pub struct RenderTarget {
    pub width: u32,
    pub height: u32,
    msaa_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    /// Resolved colour (COLOR_FORMAT), sampled by the viewport blit and copied by readback.
    pub color: wgpu::Texture,
    pub color_view: wgpu::TextureView,
    lic: LicTargets,
}

/// Targets of the LIC passes (one texel per pixel).
struct LicTargets {
    /// Screen directions of line families 0 and 1.
    dirs_view: wgpu::TextureView,
    /// Family 2, surface noise, view depth.
    misc_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    /// Pass 2 output (r = LIC intensity); kept as a texture so tests can read it.
    pub result: wgpu::Texture,
    result_view: wgpu::TextureView,
    /// Group 1 of the LIC pass (G-buffer).
    gbuffer_bind_group: wgpu::BindGroup,
    /// Group 1 of the mesh pass (LIC result).
    result_bind_group: wgpu::BindGroup,
}

impl RenderTarget {
    fn new(
        device: &wgpu::Device,
        layouts: &TargetLayouts,
        width: u32,
        height: u32,
    ) -> RenderTarget {
        let width = width.max(1);
        let height = height.max(1);
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let tex = |label, format, samples, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let msaa = tex(
            "quadcover msaa color",
            COLOR_FORMAT,
            SAMPLE_COUNT,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        let depth = tex(
            "quadcover depth",
            DEPTH_FORMAT,
            SAMPLE_COUNT,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        let color = tex(
            "quadcover color",
            COLOR_FORMAT,
            1,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        );
        let sampled = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let dirs = tex("quadcover lic dirs", LIC_FORMAT, 1, sampled);
        let misc = tex("quadcover lic misc", LIC_FORMAT, 1, sampled);
        let lic_depth = tex(
            "quadcover lic depth",
            DEPTH_FORMAT,
            1,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        let result = tex(
            "quadcover lic result",
            LIC_FORMAT,
            1,
            sampled | wgpu::TextureUsages::COPY_SRC,
        );
        let (dirs_view, misc_view, result_view) = (view(&dirs), view(&misc), view(&result));
        let gbuffer_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("quadcover lic gbuffer bg"),
            layout: &layouts.gbuffer,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&dirs_view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&misc_view),
                },
            ],
        });
        let result_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("quadcover lic result bg"),
            layout: &layouts.result,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&result_view),
            }],
        });
        RenderTarget {
            width,
            height,
            msaa_view: view(&msaa),
            depth_view: view(&depth),
            color_view: view(&color),
            color,
            lic: LicTargets {
                dirs_view,
                misc_view,
                depth_view: view(&lic_depth),
                result,
                result_view,
                gbuffer_bind_group,
                result_bind_group,
            },
        }
    }

    /// The LIC result texture (r = intensity, `LIC_FORMAT`) of the last field render.
    pub fn lic_texture(&self) -> &wgpu::Texture {
        &self.lic.result
    }
}

/// Bind-group layouts the render targets' bind groups are made with.
struct TargetLayouts {
    /// Group 1 of the LIC pass: G-buffer textures.
    gbuffer: wgpu::BindGroupLayout,
    /// Group 1 of the mesh pass: the LIC result.
    result: wgpu::BindGroupLayout,
}

/// Linear RGBA of the wireframe (the mesh shader's).
pub const WIRE_COLOR: [f32; 4] = [0.02, 0.02, 0.03, 0.85];

/// The wireframe's colour as the lines drawn for the faces drawn by patches
/// ([`SceneData::set_patches`]): the line shader blends in sRGB-encoded values where the mesh
/// shader mixes the wireframe in linear ones, so the same opacity would draw these edges much
/// darker; this one puts as much ink on a light surface as the mesh's wireframe does.
pub const PATCH_WIRE_COLOR: [f32; 4] = [0.02, 0.02, 0.03, 0.72];

/// Buffers of one uploaded scene. Built once per document change.
struct GpuScene {
    vertices: wgpu::Buffer,
    n_vertices: u32,
    /// The input faces' corners (`3 * SceneData::n_faces()`); the patches' follow
    /// ([`SceneData::set_patches`]) and are drawn without the shader's wireframe.
    n_surface: u32,
    /// The replaced faces' edges as lines of the wireframe's colour, drawn for the wireframe.
    patch_wire: Option<(wgpu::Buffer, u32)>,
    lines: Option<(wgpu::Buffer, u32)>,
    glyphs: Option<(wgpu::Buffer, u32)>,
    has_uv: bool,
    has_field: bool,
    symmetry: u32,
    radius: f32,
}

pub struct Renderer {
    mesh_pipeline: wgpu::RenderPipeline,
    /// LIC pass 1: the mesh into the G-buffer (noise, screen directions, depth).
    field_pipeline: wgpu::RenderPipeline,
    /// LIC pass 2: fullscreen streamline convolution.
    lic_pipeline: wgpu::RenderPipeline,
    target_layouts: TargetLayouts,
    line_pipeline: wgpu::RenderPipeline,
    /// Lines twice the overlay width (geometric and highlighted curves).
    thick_line_pipeline: wgpu::RenderPipeline,
    glyph_pipeline: wgpu::RenderPipeline,
    mesh_bgl: wgpu::BindGroupLayout,
    uniform_buffer: wgpu::Buffer,
    mesh_bind_group: wgpu::BindGroup,
    overlay_bind_group: wgpu::BindGroup,
    /// The uniforms again with a smaller glyph size and a thinner line width, for the overlays'
    /// dots and fine lines ([`Overlay::dots`], [`Overlay::fine_lines`]): the glyph and line
    /// pipelines draw them with this bind group.
    fine_uniform_buffer: wgpu::Buffer,
    fine_bind_group: wgpu::BindGroup,
    /// The uniforms again without the wireframe and with the wireframe's width as the line
    /// width: the scene's patches (pole stars) are drawn with `patch_mesh_bind_group` (their
    /// cells are no mesh edges) and the replaced faces' edges with `patch_overlay_bind_group`.
    patch_uniform_buffer: wgpu::Buffer,
    patch_mesh_bind_group: wgpu::BindGroup,
    patch_overlay_bind_group: wgpu::BindGroup,
    /// The remesh's polygons, fan-triangulated, drawn instead of the surface in
    /// [`RemeshDisplay::Only`] ([`Renderer::sync_remesh_surface`]).
    remesh_surface: Option<GpuSurface>,
    sampler: wgpu::Sampler,
    pattern_view: wgpu::TextureView,
    scene: Option<GpuScene>,
    /// Overlays drawn over the scene, in slot order (the constraint curves, the feature preview,
    /// the active tool's hover highlight and drag preview); small, so each is uploaded apart
    /// from the scene whenever its revision changes ([`Renderer::sync_overlays`]).
    overlays: Vec<Option<GpuOverlay>>,
    /// Number of scene uploads so far (lets tests check buffers are not rebuilt per frame).
    pub uploads: u64,
}

/// Buffers of one overlay.
struct GpuOverlay {
    revision: u64,
    fine_lines: Option<(wgpu::Buffer, u32)>,
    lines: Option<(wgpu::Buffer, u32)>,
    thick_lines: Option<(wgpu::Buffer, u32)>,
    glyphs: Option<(wgpu::Buffer, u32)>,
    dots: Option<(wgpu::Buffer, u32)>,
    over_glyphs: bool,
}

/// A second surface (per-corner vertices like the scene's), uploaded once per `key`.
struct GpuSurface {
    key: u64,
    vertices: wgpu::Buffer,
    n_vertices: u32,
}

/// A pipeline drawing one fullscreen triangle (no vertex buffers, no depth): the LIC pass and
/// the viewport's blit. The module provides `vs_main` and `fs_main`.
pub(crate) fn fullscreen_pipeline(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    targets: &[Option<wgpu::ColorTargetState>],
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// A depth attachment cleared to the far plane and discarded after the pass.
fn cleared_depth(view: &wgpu::TextureView) -> wgpu::RenderPassDepthStencilAttachment<'_> {
    wgpu::RenderPassDepthStencilAttachment {
        view,
        depth_ops: Some(wgpu::Operations {
            load: wgpu::LoadOp::Clear(1.0),
            store: wgpu::StoreOp::Discard,
        }),
        stencil_ops: None,
    }
}

fn vertex_attrs() -> [wgpu::VertexAttribute; 5] {
    wgpu::vertex_attr_array![
        0 => Float32x3, 1 => Float32x3, 2 => Float32x3, 3 => Float32x2, 4 => Float32x3
    ]
}

fn line_attrs() -> [wgpu::VertexAttribute; 3] {
    wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x4]
}

fn glyph_attrs() -> [wgpu::VertexAttribute; 2] {
    wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4]
}

/// A 2-D float texture read by the fragment stage.
pub(crate) fn fragment_texture_entry(binding: u32, filterable: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

/// A filtering sampler used by the fragment stage.
pub(crate) fn fragment_sampler_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    }
}

impl Renderer {
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Renderer {
        let mesh_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("mesh.wgsl"),
            source: wgpu::ShaderSource::Wgsl(MESH_WGSL.into()),
        });
        let overlay_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("overlay.wgsl"),
            source: wgpu::ShaderSource::Wgsl(OVERLAY_WGSL.into()),
        });
        let lic_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("lic.wgsl"),
            source: wgpu::ShaderSource::Wgsl(LIC_WGSL.into()),
        });
        let uniform_size = NonZeroU64::new(std::mem::size_of::<Uniforms>() as u64);
        let uniform_entry = wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: uniform_size,
            },
            count: None,
        };
        let mesh_bgl = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("quadcover mesh bgl"),
            entries: &[
                uniform_entry,
                fragment_texture_entry(1, true),
                fragment_sampler_entry(2),
            ],
        });
        let overlay_bgl = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("quadcover overlay bgl"),
            entries: &[uniform_entry],
        });
        let texture_entry = |binding| fragment_texture_entry(binding, false);
        let target_layouts = TargetLayouts {
            gbuffer: device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("quadcover lic gbuffer bgl"),
                entries: &[texture_entry(0), texture_entry(1)],
            }),
            result: device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("quadcover lic result bgl"),
                entries: &[texture_entry(0)],
            }),
        };
        let mesh_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("quadcover mesh layout"),
            bind_group_layouts: &[Some(&mesh_bgl), Some(&target_layouts.result)],
            immediate_size: 0,
        });
        let field_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("quadcover lic field layout"),
            bind_group_layouts: &[Some(&mesh_bgl)],
            immediate_size: 0,
        });
        let overlay_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("quadcover overlay layout"),
            bind_group_layouts: &[Some(&overlay_bgl)],
            immediate_size: 0,
        });

        let multisample = wgpu::MultisampleState {
            count: SAMPLE_COUNT,
            mask: !0,
            alpha_to_coverage_enabled: false,
        };
        let depth = |write: bool| wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(write),
            depth_compare: Some(wgpu::CompareFunction::LessEqual),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        };
        let blend_target = [Some(wgpu::ColorTargetState {
            format: COLOR_FORMAT,
            blend: Some(wgpu::BlendState::ALPHA_BLENDING),
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let opaque_target = [Some(wgpu::ColorTargetState {
            format: COLOR_FORMAT,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        })];

        // The surface: shaded (multisampled, into the colour target) and, for the LIC, the
        // G-buffer of surface noise and projected field directions (single-sampled).
        let v_attrs = vertex_attrs();
        let surface_pipeline =
            |label: &str,
             layout: &wgpu::PipelineLayout,
             fs: &str,
             targets: &[Option<wgpu::ColorTargetState>],
             multisample: wgpu::MultisampleState| {
                device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some(label),
                    layout: Some(layout),
                    vertex: wgpu::VertexState {
                        module: &mesh_module,
                        entry_point: Some("vs_main"),
                        compilation_options: Default::default(),
                        buffers: &[Some(wgpu::VertexBufferLayout {
                            array_stride: std::mem::size_of::<Vertex>() as u64,
                            step_mode: wgpu::VertexStepMode::Vertex,
                            attributes: &v_attrs,
                        })],
                    },
                    primitive: wgpu::PrimitiveState {
                        topology: wgpu::PrimitiveTopology::TriangleList,
                        cull_mode: None,
                        ..Default::default()
                    },
                    depth_stencil: Some(depth(true)),
                    multisample,
                    fragment: Some(wgpu::FragmentState {
                        module: &mesh_module,
                        entry_point: Some(fs),
                        compilation_options: Default::default(),
                        targets,
                    }),
                    multiview_mask: None,
                    cache: None,
                })
            };
        let mesh_pipeline = surface_pipeline(
            "quadcover mesh",
            &mesh_layout,
            "fs_main",
            &opaque_target,
            multisample,
        );
        let lic_targets = [
            Some(wgpu::ColorTargetState {
                format: LIC_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            }),
            Some(wgpu::ColorTargetState {
                format: LIC_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            }),
        ];
        let field_pipeline = surface_pipeline(
            "quadcover lic field",
            &field_layout,
            "fs_field",
            &lic_targets,
            wgpu::MultisampleState::default(),
        );
        let lic_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("quadcover lic layout"),
            bind_group_layouts: &[Some(&overlay_bgl), Some(&target_layouts.gbuffer)],
            immediate_size: 0,
        });
        let lic_pipeline = fullscreen_pipeline(
            device,
            "quadcover lic",
            &lic_layout,
            &lic_module,
            &lic_targets[..1],
        );
        // Lines and glyphs: instanced quads expanded in the vertex shader, blended on top.
        let overlay_pipeline =
            |label: &str,
             vs: &str,
             fs: &str,
             stride: usize,
             attributes: &[wgpu::VertexAttribute]| {
                device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some(label),
                    layout: Some(&overlay_layout),
                    vertex: wgpu::VertexState {
                        module: &overlay_module,
                        entry_point: Some(vs),
                        compilation_options: Default::default(),
                        buffers: &[Some(wgpu::VertexBufferLayout {
                            array_stride: stride as u64,
                            step_mode: wgpu::VertexStepMode::Instance,
                            attributes,
                        })],
                    },
                    primitive: wgpu::PrimitiveState::default(),
                    depth_stencil: Some(depth(false)),
                    multisample,
                    fragment: Some(wgpu::FragmentState {
                        module: &overlay_module,
                        entry_point: Some(fs),
                        compilation_options: Default::default(),
                        targets: &blend_target,
                    }),
                    multiview_mask: None,
                    cache: None,
                })
            };
        let line_pipeline = overlay_pipeline(
            "quadcover lines",
            "vs_line",
            "fs_line",
            std::mem::size_of::<LineSegment>(),
            &line_attrs(),
        );
        let thick_line_pipeline = overlay_pipeline(
            "quadcover thick lines",
            "vs_thick_line",
            "fs_line",
            std::mem::size_of::<LineSegment>(),
            &line_attrs(),
        );
        let glyph_pipeline = overlay_pipeline(
            "quadcover glyphs",
            "vs_glyph",
            "fs_glyph",
            std::mem::size_of::<Glyph>(),
            &glyph_attrs(),
        );

        let uniform_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("quadcover uniforms"),
            size: std::mem::size_of::<Uniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("quadcover pattern sampler"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            address_mode_w: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let overlay_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("quadcover overlay bg"),
            layout: &overlay_bgl,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniform_buffer.as_entire_binding(),
            }],
        });
        let fine_uniform_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("quadcover fine uniforms"),
            size: std::mem::size_of::<Uniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let fine_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("quadcover fine bg"),
            layout: &overlay_bgl,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: fine_uniform_buffer.as_entire_binding(),
            }],
        });
        let patch_uniform_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("quadcover patch uniforms"),
            size: std::mem::size_of::<Uniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let patch_overlay_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("quadcover patch overlay bg"),
            layout: &overlay_bgl,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: patch_uniform_buffer.as_entire_binding(),
            }],
        });
        let (pattern_view, mesh_bind_group, patch_mesh_bind_group) = {
            let (w, h, rgba) = default_pattern_image();
            let view = upload_rgba(device, queue, w, h, &rgba);
            let bg = mesh_bind_group(device, &mesh_bgl, &uniform_buffer, &view, &sampler);
            let patch = mesh_bind_group(device, &mesh_bgl, &patch_uniform_buffer, &view, &sampler);
            (view, bg, patch)
        };
        Renderer {
            mesh_pipeline,
            field_pipeline,
            lic_pipeline,
            target_layouts,
            line_pipeline,
            thick_line_pipeline,
            glyph_pipeline,
            mesh_bgl,
            uniform_buffer,
            mesh_bind_group,
            overlay_bind_group,
            fine_uniform_buffer,
            fine_bind_group,
            patch_uniform_buffer,
            patch_mesh_bind_group,
            patch_overlay_bind_group,
            remesh_surface: None,
            sampler,
            pattern_view,
            scene: None,
            overlays: Vec::new(),
            uploads: 0,
        }
    }

    /// Uploads the scene (vertex, line and glyph buffers). Call once per change.
    pub fn upload_scene(&mut self, device: &wgpu::Device, scene: &SceneData) {
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("quadcover vertices"),
            contents: if scene.vertices.is_empty() {
                &[0u8; std::mem::size_of::<Vertex>()]
            } else {
                bytemuck::cast_slice(&scene.vertices)
            },
            usage: wgpu::BufferUsages::VERTEX,
        });
        let instances = |label, bytes: &[u8], n: usize| instance_buffer(device, label, bytes, n);
        let wire: Vec<LineSegment> = scene
            .patch_wire
            .iter()
            .map(|&[a, b]| LineSegment {
                a,
                b,
                color: PATCH_WIRE_COLOR,
            })
            .collect();
        self.scene = Some(GpuScene {
            vertices,
            n_vertices: scene.vertices.len() as u32,
            n_surface: (3 * scene.n_faces()) as u32,
            patch_wire: instances(
                "quadcover patch wire",
                bytemuck::cast_slice(&wire),
                wire.len(),
            ),
            lines: instances(
                "quadcover lines",
                bytemuck::cast_slice(&scene.lines),
                scene.lines.len(),
            ),
            glyphs: instances(
                "quadcover glyphs",
                bytemuck::cast_slice(&scene.glyphs),
                scene.glyphs.len(),
            ),
            has_uv: scene.has_uv,
            has_field: scene.has_field,
            symmetry: scene.symmetry,
            radius: scene.radius(),
        });
        self.uploads += 1;
    }

    pub fn clear_scene(&mut self) {
        self.scene = None;
    }

    /// Replaces the overlays drawn over the scene (slot `i` is `overlays[i]`, drawn in slot
    /// order; `None` or an empty overlay draws nothing). A slot whose revision is already on the
    /// GPU is not uploaded again.
    pub fn sync_overlays(&mut self, device: &wgpu::Device, overlays: &[Option<&Overlay>]) {
        self.overlays.resize_with(overlays.len(), || None);
        for (slot, overlay) in self.overlays.iter_mut().zip(overlays) {
            let Some(o) = overlay.filter(|o| !o.is_empty()) else {
                *slot = None;
                continue;
            };
            if slot.as_ref().is_some_and(|g| g.revision == o.revision) {
                continue;
            }
            let instances = |label, lines: &[LineSegment]| {
                instance_buffer(device, label, bytemuck::cast_slice(lines), lines.len())
            };
            *slot = Some(GpuOverlay {
                revision: o.revision,
                fine_lines: instances("quadcover overlay fine lines", &o.fine_lines),
                lines: instances("quadcover overlay lines", &o.lines),
                thick_lines: instances("quadcover overlay thick lines", &o.thick_lines),
                glyphs: instance_buffer(
                    device,
                    "quadcover overlay glyphs",
                    bytemuck::cast_slice(&o.glyphs),
                    o.glyphs.len(),
                ),
                dots: instance_buffer(
                    device,
                    "quadcover overlay dots",
                    bytemuck::cast_slice(&o.dots),
                    o.dots.len(),
                ),
                over_glyphs: o.over_glyphs,
            });
        }
    }

    /// The revisions of the overlays on the GPU, by slot (tests check uploads are skipped).
    pub fn overlay_revisions(&self) -> Vec<Option<u64>> {
        self.overlays
            .iter()
            .map(|o| o.as_ref().map(|g| g.revision))
            .collect()
    }

    pub fn has_scene(&self) -> bool {
        self.scene.is_some()
    }

    /// Uploads the remesh's surface (per-corner vertices of its fan-triangulated polygons)
    /// unless the one with this `key` is on the GPU already; `None` removes it.
    pub fn sync_remesh_surface(
        &mut self,
        device: &wgpu::Device,
        surface: Option<(u64, &SceneData)>,
    ) {
        let Some((key, s)) = surface.filter(|(_, s)| !s.vertices.is_empty()) else {
            self.remesh_surface = None;
            return;
        };
        if self.remesh_surface.as_ref().is_some_and(|g| g.key == key) {
            return;
        }
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("quadcover remesh surface"),
            contents: bytemuck::cast_slice(&s.vertices),
            usage: wgpu::BufferUsages::VERTEX,
        });
        self.remesh_surface = Some(GpuSurface {
            key,
            vertices,
            n_vertices: s.vertices.len() as u32,
        });
    }

    /// The key of the remesh surface on the GPU (tests check what is drawn).
    pub fn remesh_surface_key(&self) -> Option<u64> {
        self.remesh_surface.as_ref().map(|g| g.key)
    }

    /// Whether these settings draw the remesh's polygons instead of the surface (they ask
    /// for it and there is one: stripes have no polygons, the surface stays).
    pub fn remesh_only(&self, settings: &DisplaySettings) -> bool {
        settings.remesh == RemeshDisplay::Only && self.remesh_surface.is_some()
    }

    /// Creates the render targets for a `width` x `height` image (call again only on resize).
    pub fn create_target(&self, device: &wgpu::Device, width: u32, height: u32) -> RenderTarget {
        RenderTarget::new(device, &self.target_layouts, width, height)
    }

    /// Whether `render` runs the LIC passes with these settings.
    fn lic_active(&self, settings: &DisplaySettings) -> bool {
        !self.remesh_only(settings)
            && settings.mode == DisplayMode::Field
            && self
                .scene
                .as_ref()
                .is_some_and(|s| s.has_field && s.n_vertices > 0)
    }

    /// Replaces the image used by [`Pattern::Image`] (RGBA8, sRGB-encoded).
    pub fn set_pattern_image(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        width: u32,
        height: u32,
        rgba: &[u8],
    ) {
        self.pattern_view = upload_rgba(device, queue, width, height, rgba);
        self.mesh_bind_group = mesh_bind_group(
            device,
            &self.mesh_bgl,
            &self.uniform_buffer,
            &self.pattern_view,
            &self.sampler,
        );
        self.patch_mesh_bind_group = mesh_bind_group(
            device,
            &self.mesh_bgl,
            &self.patch_uniform_buffer,
            &self.pattern_view,
            &self.sampler,
        );
    }

    pub fn uniforms(
        &self,
        camera: &OrbitCamera,
        settings: &DisplaySettings,
        width: u32,
        height: u32,
    ) -> Uniforms {
        let (mut has_uv, mut has_field, symmetry, radius) = match &self.scene {
            Some(s) => (s.has_uv, s.has_field, s.symmetry, s.radius),
            None => (false, false, 4, 1.0),
        };
        let aspect = width as f32 / height.max(1) as f32;
        let eye = camera.eye();
        let mut pattern = match settings.mode {
            DisplayMode::Pattern => settings.pattern,
            _ => Pattern::None,
        };
        // The remesh's polygons are shaded plain: no UVs, no field, and its own edges are
        // drawn as lines (a wireframe would show the fans' diagonals).
        let remesh_only = self.remesh_only(settings);
        if remesh_only {
            (has_uv, has_field, pattern) = (false, false, Pattern::None);
        }
        let b = settings.base_color;
        Uniforms {
            view_proj: camera.view_proj(aspect).to_cols_array_2d(),
            camera_pos: [eye.x, eye.y, eye.z, radius],
            light_dir: camera.light_dir().extend(0.18).to_array(),
            base_color: [b[0], b[1], b[2], 1.0],
            wire_color: WIRE_COLOR,
            pattern_color: [0.03, 0.03, 0.05, 0.75],
            params: [
                settings.pattern_scale,
                settings.line_width,
                settings.line_width * 1.4,
                settings.lic_cell_px,
            ],
            params2: [
                settings.lic_strength,
                settings.lic_length,
                settings.glyph_size_px,
                settings.overlay_line_width_px,
            ],
            viewport: [
                width as f32,
                height as f32,
                1.0 / width.max(1) as f32,
                1.0 / height.max(1) as f32,
            ],
            modes: [
                (settings.shading == Shading::Flat) as u32,
                pattern as u32,
                (settings.wireframe && !remesh_only) as u32,
                symmetry,
            ],
            flags: [
                (settings.mode == DisplayMode::Field && !remesh_only) as u32,
                has_uv as u32,
                has_field as u32,
                // twisted stripes (n, k), 16 bits each
                (settings.stripe_twist[0].clamp(1, 0xffff))
                    | (settings.stripe_twist[1].min(0xffff) << 16),
            ],
        }
    }

    /// Encodes the scene render into `target` (clears it first).
    pub fn render(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        target: &RenderTarget,
        camera: &OrbitCamera,
        settings: &DisplaySettings,
    ) {
        let mut u = self.uniforms(camera, settings, target.width, target.height);
        queue.write_buffer(&self.uniform_buffer, 0, bytemuck::bytes_of(&u));
        let wireframe = u.modes[2] == 1;
        let mut patch = u;
        patch.modes[2] = 0;
        patch.params2[3] = settings.line_width;
        queue.write_buffer(&self.patch_uniform_buffer, 0, bytemuck::bytes_of(&patch));
        u.params2[2] = dot_size_px(settings.glyph_size_px);
        u.params2[3] = fine_line_px(settings.line_width);
        queue.write_buffer(&self.fine_uniform_buffer, 0, bytemuck::bytes_of(&u));
        if self.lic_active(settings) {
            self.render_lic(encoder, target);
        }
        let bg = settings.background;
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("quadcover scene"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &target.msaa_view,
                resolve_target: Some(&target.color_view),
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color {
                        r: bg[0] as f64 / 255.0,
                        g: bg[1] as f64 / 255.0,
                        b: bg[2] as f64 / 255.0,
                        a: 1.0,
                    }),
                    store: wgpu::StoreOp::Discard,
                },
                depth_slice: None,
            })],
            depth_stencil_attachment: Some(cleared_depth(&target.depth_view)),
            occlusion_query_set: None,
            timestamp_writes: None,
            multiview_mask: None,
        });
        let Some(scene) = &self.scene else {
            return;
        };
        // The surface: its input faces, then the patches (pole stars) without the shader's
        // wireframe and, for it, the replaced faces' edges as lines.
        let remesh_only = self.remesh_only(settings);
        let (surface, n, n_surface) = match &self.remesh_surface {
            Some(r) if remesh_only => (&r.vertices, r.n_vertices, r.n_vertices),
            _ => (&scene.vertices, scene.n_vertices, scene.n_surface),
        };
        if n > 0 {
            pass.set_pipeline(&self.mesh_pipeline);
            pass.set_bind_group(0, &self.mesh_bind_group, &[]);
            pass.set_bind_group(1, &target.lic.result_bind_group, &[]);
            pass.set_vertex_buffer(0, surface.slice(..));
            if n_surface > 0 {
                pass.draw(0..n_surface, 0..1);
            }
            if n > n_surface {
                pass.set_bind_group(0, &self.patch_mesh_bind_group, &[]);
                pass.draw(n_surface..n, 0..1);
            }
        }
        if wireframe
            && !remesh_only
            && let Some((buf, n)) = &scene.patch_wire
        {
            pass.set_pipeline(&self.line_pipeline);
            pass.set_bind_group(0, &self.patch_overlay_bind_group, &[]);
            pass.set_vertex_buffer(0, buf.slice(..));
            pass.draw(0..6, 0..*n);
        }
        if settings.show_lines
            && let Some((buf, n)) = &scene.lines
        {
            pass.set_pipeline(&self.line_pipeline);
            pass.set_bind_group(0, &self.overlay_bind_group, &[]);
            pass.set_vertex_buffer(0, buf.slice(..));
            pass.draw(0..6, 0..*n);
        }
        // Overlay lines over the scene's (the cut graph), glyphs over those lines, then the
        // overlays drawn over the glyphs.
        let draw_with = |pass: &mut wgpu::RenderPass<'_>,
                         pipeline: &wgpu::RenderPipeline,
                         bind_group: &wgpu::BindGroup,
                         instances: &Option<(wgpu::Buffer, u32)>| {
            if let Some((buf, n)) = instances {
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, bind_group, &[]);
                pass.set_vertex_buffer(0, buf.slice(..));
                pass.draw(0..6, 0..*n);
            }
        };
        let draw = |pass: &mut wgpu::RenderPass<'_>,
                    pipeline: &wgpu::RenderPipeline,
                    instances: &Option<(wgpu::Buffer, u32)>| {
            draw_with(pass, pipeline, &self.overlay_bind_group, instances);
        };
        let under = || self.overlays.iter().flatten().filter(|o| !o.over_glyphs);
        let fine = &self.fine_bind_group;
        for overlay in under() {
            draw_with(&mut pass, &self.line_pipeline, fine, &overlay.fine_lines);
            draw(&mut pass, &self.line_pipeline, &overlay.lines);
            draw(&mut pass, &self.thick_line_pipeline, &overlay.thick_lines);
        }
        if settings.show_singularities {
            draw(&mut pass, &self.glyph_pipeline, &scene.glyphs);
        }
        for overlay in under() {
            draw(&mut pass, &self.glyph_pipeline, &overlay.glyphs);
        }
        // Overlays over the glyphs (the folds), in slot order.
        for overlay in self.overlays.iter().flatten().filter(|o| o.over_glyphs) {
            draw_with(&mut pass, &self.line_pipeline, fine, &overlay.fine_lines);
            draw(&mut pass, &self.line_pipeline, &overlay.lines);
            draw(&mut pass, &self.thick_line_pipeline, &overlay.thick_lines);
            draw(&mut pass, &self.glyph_pipeline, &overlay.glyphs);
        }
        // Dots last, smaller than glyphs: over everything.
        for overlay in self.overlays.iter().flatten() {
            draw_with(&mut pass, &self.glyph_pipeline, fine, &overlay.dots);
        }
    }
}

impl Renderer {
    /// LIC passes 1 and 2 (uniforms already written): the mesh into the
    /// G-buffer, then the streamline convolution into the LIC result texture.
    fn render_lic(&self, encoder: &mut wgpu::CommandEncoder, target: &RenderTarget) {
        let Some(scene) = &self.scene else {
            return;
        };
        let clear = wgpu::Operations {
            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
            store: wgpu::StoreOp::Store,
        };
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("quadcover lic gbuffer"),
                color_attachments: &[
                    Some(wgpu::RenderPassColorAttachment {
                        view: &target.lic.dirs_view,
                        resolve_target: None,
                        ops: clear,
                        depth_slice: None,
                    }),
                    Some(wgpu::RenderPassColorAttachment {
                        view: &target.lic.misc_view,
                        resolve_target: None,
                        ops: clear,
                        depth_slice: None,
                    }),
                ],
                depth_stencil_attachment: Some(cleared_depth(&target.lic.depth_view)),
                occlusion_query_set: None,
                timestamp_writes: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.field_pipeline);
            pass.set_bind_group(0, &self.mesh_bind_group, &[]);
            pass.set_vertex_buffer(0, scene.vertices.slice(..));
            pass.draw(0..scene.n_vertices, 0..1);
        }
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("quadcover lic convolution"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &target.lic.result_view,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color {
                        r: 0.5,
                        g: 0.0,
                        b: 0.0,
                        a: 1.0,
                    }),
                    store: wgpu::StoreOp::Store,
                },
                depth_slice: None,
            })],
            depth_stencil_attachment: None,
            occlusion_query_set: None,
            timestamp_writes: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.lic_pipeline);
        pass.set_bind_group(0, &self.overlay_bind_group, &[]);
        pass.set_bind_group(1, &target.lic.gbuffer_bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
}

fn mesh_bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    uniforms: &wgpu::Buffer,
    view: &wgpu::TextureView,
    sampler: &wgpu::Sampler,
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("quadcover mesh bg"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(view),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::Sampler(sampler),
            },
        ],
    })
}

/// Uploads an sRGB RGBA8 image as an `Rgba8Unorm` texture (the shader works on
/// encoded values, like the rest of the pipeline).
fn upload_rgba(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    width: u32,
    height: u32,
    rgba: &[u8],
) -> wgpu::TextureView {
    let size = wgpu::Extent3d {
        width,
        height,
        depth_or_array_layers: 1,
    };
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("quadcover pattern image"),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    queue.write_texture(
        texture.as_image_copy(),
        rgba,
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(4 * width),
            rows_per_image: Some(height),
        },
        size,
    );
    texture.create_view(&Default::default())
}

/// A small built-in image for the image pattern: an "F" glyph, which shows the
/// orientation of the parameterization (it has no rotational symmetry).
pub fn default_pattern_image() -> (u32, u32, Vec<u8>) {
    let n = 64u32;
    let mut rgba = Vec::with_capacity((n * n * 4) as usize);
    for y in 0..n {
        for x in 0..n {
            // texture v grows upwards in parameter space; rows are stored top-down
            let (fx, fy) = (x as f32 / n as f32, 1.0 - (y as f32 + 0.5) / n as f32);
            let stem = (0.25..0.4).contains(&fx) && (0.15..0.85).contains(&fy);
            let top = (0.25..0.75).contains(&fx) && (0.72..0.85).contains(&fy);
            let mid = (0.25..0.62).contains(&fx) && (0.45..0.57).contains(&fy);
            let ink = stem || top || mid;
            let c = if ink {
                [200u8, 40, 30, 255]
            } else {
                [235, 225, 200, 255]
            };
            rgba.extend_from_slice(&c);
        }
    }
    (n, n, rgba)
}

/// Copies a `COLOR_FORMAT` texture to the CPU as tightly packed RGBA8 rows.
pub fn read_rgba(device: &wgpu::Device, queue: &wgpu::Queue, texture: &wgpu::Texture) -> Vec<u8> {
    let width = texture.width();
    let height = texture.height();
    let unpadded = 4 * width;
    let padded =
        unpadded.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("quadcover readback"),
        size: (padded * height) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: None,
            },
        },
        texture.size(),
    );
    queue.submit([encoder.finish()]);
    let slice = buffer.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    let _ = device.poll(wgpu::PollType::wait_indefinitely());
    let mut out = Vec::with_capacity((unpadded * height) as usize);
    if let Ok(Ok(())) = rx.recv() {
        if let Ok(mapped) = slice.get_mapped_range() {
            for row in mapped.chunks(padded as usize) {
                out.extend_from_slice(&row[..unpadded as usize]);
            }
        }
        buffer.unmap();
    }
    out
}

/// Renders with an existing device: the same path as the viewport, then reads
/// the resolved colour back. Returns RGBA8 (sRGB) rows, top row first.
pub fn render_to_rgba(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    renderer: &Renderer,
    camera: &OrbitCamera,
    settings: &DisplaySettings,
    width: u32,
    height: u32,
) -> image::RgbaImage {
    let target = renderer.create_target(device, width, height);
    let mut encoder = device.create_command_encoder(&Default::default());
    renderer.render(queue, &mut encoder, &target, camera, settings);
    queue.submit([encoder.finish()]);
    let data = read_rgba(device, queue, &target.color);
    image::RgbaImage::from_raw(target.width, target.height, data)
        .unwrap_or_else(|| image::RgbaImage::new(target.width, target.height))
}

/// A headless device + renderer (for tests and the CLI).
pub struct Offscreen {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub renderer: Renderer,
    pub adapter_info: wgpu::AdapterInfo,
}

impl Offscreen {
    /// Creates a device on any adapter (honours `WGPU_BACKEND`). `Err` when
    /// there is no adapter.
    pub fn new() -> Result<Offscreen, String> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            ..Default::default()
        }))
        .map_err(|e| format!("no wgpu adapter: {e}"))?;
        let adapter_info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("quadcover offscreen"),
            required_features: wgpu::Features::empty(),
            required_limits: wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits()),
            ..Default::default()
        }))
        .map_err(|e| format!("cannot create wgpu device: {e}"))?;
        let renderer = Renderer::new(&device, &queue);
        Ok(Offscreen {
            device,
            queue,
            renderer,
            adapter_info,
        })
    }

    pub fn upload(&mut self, scene: &SceneData) {
        self.renderer.upload_scene(&self.device, scene);
    }

    pub fn render(
        &self,
        camera: &OrbitCamera,
        settings: &DisplaySettings,
        width: u32,
        height: u32,
    ) -> image::RgbaImage {
        render_to_rgba(
            &self.device,
            &self.queue,
            &self.renderer,
            camera,
            settings,
            width,
            height,
        )
    }
}

/// Diameter of an overlay dot ([`Overlay::dots`]) for the glyph size, pixels.
pub fn dot_size_px(glyph_size_px: f32) -> f32 {
    (0.5 * glyph_size_px).max(5.0)
}

/// Width of an overlay's fine lines ([`Overlay::fine_lines`]) for the pattern line width: that
/// of the pattern's lines, pixels.
pub fn fine_line_px(line_width: f32) -> f32 {
    (1.4 * line_width).max(1.0)
}

/// A vertex buffer of `n` instances (`None` when there are none: wgpu refuses empty buffers).
fn instance_buffer(
    device: &wgpu::Device,
    label: &str,
    bytes: &[u8],
    n: usize,
) -> Option<(wgpu::Buffer, u32)> {
    (n > 0).then(|| {
        let b = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytes,
            usage: wgpu::BufferUsages::VERTEX,
        });
        (b, n as u32)
    })
}
