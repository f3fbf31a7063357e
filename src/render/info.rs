//! What a render's frame says about itself, known from the scene before anything is drawn:
//! the channels it writes ([`scene_channels`]) and the facts its outputs record
//! ([`FrameInfo`]: camera, method, device, and the `extra` keys of each option in effect).

use super::{params, Renderer};
use crate::field::Grid;
use crate::frame::{Channel, FrameInfo};
use crate::scene::{Method, Normals, Projection, Scene};

/// The channels a render of `scene` writes (what `output::exr::written_channels` finds in its
/// frame, known before rendering): every always-written one, `crossings` where the method
/// counts them, `iso_index` with several isovalues, `color.value` with `[color] by`.
pub fn scene_channels(scene: &Scene) -> Vec<Channel> {
    let counted = scene.render.method != Method::FixedStep && scene.render.count_crossings;
    Channel::ALL
        .into_iter()
        .filter(|c| match c {
            Channel::Crossings => counted,
            Channel::Surface => scene.surface.several(),
            Channel::ColorValue => scene.color.by != crate::scene::ColorBy::Surface,
            _ => c.written() == crate::frame::Written::Always,
        })
        .collect()
}

/// The files `isoview render` writes for one frame of `scene` (its EXR at `exr`, its PNG
/// preview at `png`): the channels of [`scene_channels`], and beside the frame's own header
/// how the isovalue was picked (`isoview/extra/isovalue_rule`) when the data picked it. Every
/// caller that writes a scene's frame goes through here, so its files are the CLI's byte for
/// byte.
pub fn scene_files(
    scene: &Scene,
    exr: &std::path::Path,
    png: Option<&std::path::Path>,
) -> crate::output::frame_files::FrameFiles {
    let mut files = crate::output::frame_files::FrameFiles::new(exr, png, scene_channels(scene));
    if let Some(how) = scene.surface.rule.describe(scene.surface.isovalue) {
        files = files.with_header("isovalue_rule", &how);
    }
    files
}

impl Renderer {
    pub(crate) fn frame_info(&self, scene: &Scene, grid: &Grid, time: f64) -> FrameInfo {
        let r = &scene.render;
        let mut extra = vec![
            ("shading".to_string(), r.shading.name().to_string()),
            ("inside".to_string(), format!("{:?}", scene.surface.inside).to_lowercase()),
            ("grid".to_string(), format!("{}x{}x{}", grid.dims[0], grid.dims[1], grid.dims[2])),
            ("steps_scale".to_string(), format!("{}", params::steps_scale(scene, grid))),
        ];
        match r.method {
            Method::FixedStep => extra.push(("steps".into(), r.steps.to_string())),
            Method::Analytic => {
                extra.push(("newton_steps".into(), r.newton_steps.to_string()));
                extra.push(("skip".into(), r.skip.to_string()));
                extra.push(("crossing".into(), r.crossing.to_string()));
            }
            Method::Mesh => extra.push(("mesh".into(), r.mesh.name().to_string())),
        }
        if scene.surface.several() {
            let isos: Vec<String> = scene.surface.isovalues().iter().map(f64::to_string).collect();
            extra.push(("isovalues".into(), format!("[{}]", isos.join(", "))));
            let colors: Vec<String> = (0..scene.surface.count)
                .map(|k| {
                    let [r, g, b] = scene.surface.color(k, r.color);
                    format!("[{r}, {g}, {b}]")
                })
                .collect();
            extra.push(("surface_colors".into(), colors.join("; ")));
        }
        if scene.color.by != crate::scene::ColorBy::Surface {
            extra.push(("color.by".into(), scene.color.by.name().into()));
            extra.push(("color.colormap".into(), scene.color.colormap_name().into()));
            if let Some([lo, hi]) = scene.color.range {
                extra.push(("color.range".into(), format!("[{lo}, {hi}]")));
            }
        }
        if scene.clip.count > 0 {
            let planes: Vec<String> = scene
                .clip
                .planes()
                .iter()
                .map(|(n, o)| format!("[{}, {}, {}] {}", n.x, n.y, n.z, o))
                .collect();
            extra.push(("clip".into(), planes.join("; ")));
        }
        if scene.render.normals != Normals::Trilinear {
            extra.push(("normals".into(), scene.render.normals.name().into()));
        }
        if scene.camera.projection == Projection::Orthographic {
            extra.push(("projection".into(), "orthographic".into()));
            extra.push(("ortho_height".into(), scene.camera.ortho_height.to_string()));
        }
        if let Some(p) = crate::output::describe_placement(&scene.field.placement) {
            extra.push(("placement".into(), p));
        }
        if r.method != Method::FixedStep {
            // Whether the `crossings` channel was counted (it is absent when not).
            extra.push(("count_crossings".into(), r.count_crossings.to_string()));
        }
        FrameInfo {
            scene: scene.path.as_ref().map(|p| p.display().to_string()).unwrap_or_default(),
            eye: scene.camera.eye,
            target: scene.camera.target,
            up: scene.camera.up,
            fov_y_deg: scene.camera.fov_y_deg,
            ortho_height: (scene.camera.projection == Projection::Orthographic)
                .then_some(scene.camera.ortho_height),
            isovalue: scene.surface.isovalue,
            method: r.method.name().to_string(),
            time,
            device: self.ctx.info.name.clone(),
            driver: self.ctx.info.driver_info.clone(),
            extra,
            legend: None,
        }
    }
}
