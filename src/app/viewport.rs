//! The egui paint callback: renders the scene into the renderer's own
//! multisampled colour + depth target during `prepare`, then blits the
//! resolved texture into egui's render pass during `paint`.

use std::sync::Arc;

use super::camera::OrbitCamera;
use super::render::{
    BLIT_WGSL, RenderTarget, Renderer, fragment_sampler_entry, fragment_texture_entry,
    fullscreen_pipeline,
};
use super::scene::{Overlay, SceneData};
use super::settings::DisplaySettings;

/// Lives in `egui_wgpu::CallbackResources`.
pub struct ViewportResources {
    pub renderer: Renderer,
    target: Option<RenderTarget>,
    blit_pipeline: wgpu::RenderPipeline,
    blit_bgl: wgpu::BindGroupLayout,
    blit_sampler: wgpu::Sampler,
    blit_bind_group: Option<wgpu::BindGroup>,
    /// Revision of the scene currently uploaded.
    pub scene_revision: Option<u64>,
}

impl ViewportResources {
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        target_format: wgpu::TextureFormat,
    ) -> ViewportResources {
        let renderer = Renderer::new(device, queue);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("blit.wgsl"),
            source: wgpu::ShaderSource::Wgsl(BLIT_WGSL.into()),
        });
        let blit_bgl = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("quadcover blit bgl"),
            entries: &[fragment_texture_entry(0, true), fragment_sampler_entry(1)],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("quadcover blit layout"),
            bind_group_layouts: &[Some(&blit_bgl)],
            immediate_size: 0,
        });
        let blit_pipeline = fullscreen_pipeline(
            device,
            "quadcover blit",
            &layout,
            &module,
            &[Some(target_format.into())],
        );
        let blit_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("quadcover blit sampler"),
            mag_filter: wgpu::FilterMode::Nearest,
            min_filter: wgpu::FilterMode::Nearest,
            ..Default::default()
        });
        ViewportResources {
            renderer,
            target: None,
            blit_pipeline,
            blit_bgl,
            blit_sampler,
            blit_bind_group: None,
            scene_revision: None,
        }
    }

    fn ensure_target(&mut self, device: &wgpu::Device, width: u32, height: u32) {
        let ok = self
            .target
            .as_ref()
            .is_some_and(|t| t.width == width.max(1) && t.height == height.max(1));
        if ok {
            return;
        }
        let target = self.renderer.create_target(device, width, height);
        self.blit_bind_group = Some(device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("quadcover blit bg"),
            layout: &self.blit_bgl,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&target.color_view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Sampler(&self.blit_sampler),
                },
            ],
        }));
        self.target = Some(target);
    }

    /// Uploads `scene` unless `revision` is already on the GPU.
    pub fn sync_scene(&mut self, device: &wgpu::Device, revision: u64, scene: Option<&SceneData>) {
        if self.scene_revision == Some(revision) {
            return;
        }
        match scene {
            Some(s) => self.renderer.upload_scene(device, s),
            None => self.renderer.clear_scene(),
        }
        self.scene_revision = Some(revision);
    }

    /// Uploads the overlays whose revisions are not on the GPU yet (slot order is draw order).
    pub fn sync_overlays(&mut self, device: &wgpu::Device, overlays: &[Option<Arc<Overlay>>]) {
        let slots: Vec<Option<&Overlay>> = overlays.iter().map(|o| o.as_deref()).collect();
        self.renderer.sync_overlays(device, &slots);
    }
}

/// One frame's request. Cheap to build every frame: the scene is shared and
/// only uploaded when `revision` changes.
pub struct ViewportCallback {
    pub camera: OrbitCamera,
    pub settings: DisplaySettings,
    pub size_px: [u32; 2],
    pub revision: u64,
    pub scene: Option<Arc<SceneData>>,
    /// Overlays in draw order: the remesh, the constraint curves, the feature preview, the
    /// folds, the active tool's (selection, drag preview).
    pub overlays: Vec<Option<Arc<Overlay>>>,
    /// The remesh's fan-triangulated polygons and their key (uploaded once per key), drawn
    /// instead of the surface when the settings say so ([`super::settings::RemeshDisplay`]).
    pub remesh_surface: Option<(u64, Arc<SceneData>)>,
}

impl egui_wgpu::CallbackTrait for ViewportCallback {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &egui_wgpu::ScreenDescriptor,
        encoder: &mut wgpu::CommandEncoder,
        resources: &mut egui_wgpu::CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        let Some(res) = resources.get_mut::<ViewportResources>() else {
            return Vec::new();
        };
        res.sync_scene(device, self.revision, self.scene.as_deref());
        res.sync_overlays(device, &self.overlays);
        let surface = self.remesh_surface.as_ref().map(|(k, s)| (*k, s.as_ref()));
        res.renderer.sync_remesh_surface(device, surface);
        res.ensure_target(device, self.size_px[0], self.size_px[1]);
        if let Some(target) = &res.target {
            res.renderer
                .render(queue, encoder, target, &self.camera, &self.settings);
        }
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &egui_wgpu::CallbackResources,
    ) {
        let Some(res) = resources.get::<ViewportResources>() else {
            return;
        };
        if let Some(bg) = &res.blit_bind_group {
            pass.set_pipeline(&res.blit_pipeline);
            pass.set_bind_group(0, bg, &[]);
            pass.draw(0..3, 0..1);
        }
    }
}
