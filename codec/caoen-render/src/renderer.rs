//! Rendering a scene: each object is drawn by the chosen method into a shared
//! nearest-hit buffer at the supersampled resolution, the buffer is shaded in linear
//! light, and `n x n` blocks are averaged into the final pixels.
//!
//! | object  | `mesh`                           | `depth`        | `ray`          |
//! |---------|----------------------------------|----------------|----------------|
//! | surface | tessellated mesh, z-buffered     | depth buffer   | depth buffer   |
//! | solid   | marching-tetrahedra mesh         | ray traced     | ray traced     |
//!
//! A parametric Cao En surface has no implicit form to ray trace, and an implicit solid
//! has no domain to sample, so each falls back to the method that exists for it.

use std::sync::atomic::{AtomicU64, Ordering};

use rayon::prelude::*;

use super::camera::Camera;
pub use super::csg::{csg_field, first_span, polygonise_solids, trace_solids, tracers};
use super::depth_buffer::{depth_buffer, DepthBufferOptions};
use super::error::{RenderError, Result};
use super::framebuffer::{DepthMap, GBuffer, Hit, RgbImage};
use super::raster::rasterise;
use super::rays::RayScene;
use super::scene::{Scene, Shape};
use super::texture::{domain_uv, Wrap};
use caoen_geometry::mesh::Mesh;
use caoen_geometry::transform::Affine;
use caoen_geometry::vector::{dot, sub};
use caoen_surface::normals::{point_and_normal, NormalNetwork};
use caoen_surface::tessellate::{tessellate, NormalMode};
use caoen_surface::tracer::RayMethod;
use caoen_surface::SurfaceModel;

/// The rendering method (paper section 7).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// Tessellate and rasterise (solids: polygonise and rasterise).
    #[default]
    Mesh,
    /// Sample the domain into a depth buffer (solids: ray traced).
    Depth,
    /// Ray trace implicit solids (surfaces: depth buffer).
    Ray,
}

/// Render parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    /// Output width in pixels.
    pub width: u32,
    /// Output height in pixels.
    pub height: u32,
    /// Supersampling: `samples x samples` per pixel.
    pub samples: u32,
    /// Method.
    pub method: Method,
    /// Tessellation level for the mesh method (objects may override).
    pub mesh_detail: u32,
    /// Exact or interpolated normals for surfaces.
    pub normals: NormalMode,
    /// Depth-buffer parameters.
    pub depth: DepthBufferOptions,
    /// Crossing search for implicit solids.
    pub ray_method: RayMethod,
    /// Marching-tetrahedra cells along the longest side of a solid's box (mesh method).
    pub polygonise_cells: usize,
    /// Project mesh vertices through the paper's camera network (section 5) instead of
    /// the exact camera: axis generators for an orthographic camera (exact), shape
    /// vectors projected to the screen for a perspective one (an approximation).
    pub network_camera: bool,
    /// The memory the render may take (with what its job already holds).
    pub limits: caoen_base::budget::Limits,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 512,
            height: 384,
            samples: 2,
            method: Method::Mesh,
            mesh_detail: 6,
            normals: NormalMode::Exact,
            depth: DepthBufferOptions::default(),
            ray_method: RayMethod::Fast,
            polygonise_cells: 128,
            network_camera: false,
            limits: caoen_base::budget::Limits::default(),
        }
    }
}

/// Counters of one render.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RenderStats {
    /// Triangles rasterised.
    pub triangles: usize,
    /// Depth-buffer surface samples.
    pub depth_samples: usize,
    /// Depth-buffer triangles left above the size threshold.
    pub unresolved: usize,
    /// Rays traced against solids.
    pub rays: usize,
    /// With the network camera: how far its projected vertices lie from the exact
    /// camera's, in output pixels, `[max, mean]`.
    pub projection_error: Option<[f64; 2]>,
}

/// A finished render.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// The image, linear light, `width x height`.
    pub image: RgbImage,
    /// Nearest depth per output pixel.
    pub depth: DepthMap,
    /// Counters.
    pub stats: RenderStats,
}

/// Work units of progress per stage (objects, then shading).
const UNITS: u64 = 1000;

/// Reports progress as `(done, total)`; shared by the stages of one render.
struct Progress<'a> {
    total: u64,
    stage: AtomicU64,
    report: &'a (dyn Fn(u64, u64) + Sync),
}

impl Progress<'_> {
    fn within(&self, done: u64, of: u64) {
        let base = self.stage.load(Ordering::Relaxed) * UNITS;
        (self.report)(base + done * UNITS / of.max(1), self.total);
    }
    fn next(&self) {
        let s = self.stage.fetch_add(1, Ordering::Relaxed) + 1;
        (self.report)(s * UNITS, self.total);
    }
}

fn check(opts: &RenderOptions) -> Result<()> {
    if !(1..=8).contains(&opts.samples) {
        return Err(RenderError::parameter(
            "samples",
            format!("{} is not in 1..=8", opts.samples),
        ));
    }
    let px = opts.width as u64 * opts.height as u64 * (opts.samples as u64).pow(2);
    if opts.width == 0 || opts.height == 0 || px > 1 << 26 {
        return Err(RenderError::parameter(
            "size",
            format!(
                "{}x{} with {}x{} samples: must be non-empty and at most 2^26 subpixels",
                opts.width, opts.height, opts.samples, opts.samples
            ),
        ));
    }
    if opts.mesh_detail > 9 {
        return Err(RenderError::parameter("mesh detail", "must be at most 9"));
    }
    if !(4..=1024).contains(&opts.polygonise_cells) {
        return Err(RenderError::parameter(
            "polygonise cells",
            "must be in 4..=1024",
        ));
    }
    if opts.network_camera && opts.method != Method::Mesh {
        return Err(RenderError::parameter(
            "camera",
            "the network camera projects mesh vertices: use the mesh method",
        ));
    }
    Ok(())
}

/// Peak memory of one render of `width x height` pixels at `samples x samples`
/// subpixels: the hit buffer, the shaded samples and the depth map, 80 bytes a subpixel.
pub fn render_memory(width: u32, height: u32, samples: u32) -> u64 {
    caoen_base::budget::bytes(
        u64::from(width) * u64::from(height),
        u64::from(samples).pow(2),
        80,
    )
}

/// Renders `scene`; `progress` receives `(done, total)` work units.
pub fn render(
    scene: &Scene,
    opts: &RenderOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Rendered> {
    check(opts)?;
    let n = opts.samples;
    let camera = scene
        .camera(opts.width, opts.height)?
        .with_size(opts.width * n, opts.height * n);
    // `.cae` image maps decoded at this camera's footprint, their estimate checked
    // with the render's own buffers before they are decoded.
    let buffers = buffers_memory(&camera);
    let prepared =
        super::cae_texture::with_footprint_textures(scene, &camera, buffers, &opts.limits)?;
    let scene = prepared.as_ref().unwrap_or(scene);
    // Shading weighs in the bar as its share of the estimated ray tests, so that the
    // time left holds when shadow rays to many lights or deep mirrors dominate.
    let draw_units = scene.objects.len() as u64 * UNITS;
    let shade_units = (draw_units as f64 * crate::work::estimate(scene, opts).shading_ratio())
        .clamp(UNITS as f64, 1e15) as u64;
    let prog = Progress {
        total: draw_units + shade_units,
        stage: AtomicU64::new(0),
        report: progress,
    };
    // `_held` counts the meshes until the secondary rays are done with them.
    let (buf, stats, meshes, _held) = draw(scene, &camera, opts, &prog)?;
    let radius = scene.bounds()?.1;
    let rays = RayScene::new(scene, meshes, opts.ray_method, radius, &opts.limits)?;
    let shaded = |done: u64, of: u64| {
        let part = (done as f64 / of.max(1) as f64 * shade_units as f64) as u64;
        progress(draw_units + part, draw_units + shade_units);
    };
    let image = shade_buffer(scene, &camera, &buf, &rays, &shaded).downsample(n);
    progress(draw_units + shade_units, draw_units + shade_units);
    Ok(Rendered {
        image,
        depth: buf.depth_map(n),
        stats,
    })
}

/// Draws every object of `scene` through `camera` (at the camera's own size) into a
/// nearest-hit buffer, without shading: the common ground the methods are compared on.
pub fn render_gbuffer(
    scene: &Scene,
    camera: &Camera,
    opts: &RenderOptions,
) -> Result<(GBuffer, RenderStats)> {
    check(&RenderOptions {
        samples: 1,
        ..opts.clone()
    })?;
    let prog = Progress {
        total: 1,
        stage: AtomicU64::new(0),
        report: &|_, _| {},
    };
    draw(scene, camera, opts, &prog).map(|(buf, stats, _, _)| (buf, stats))
}

/// The buffers of a render by `camera` (at its supersampled size): per sample the hit
/// buffer, a surface's depth-buffer image, the shaded colour and the depth map.
fn buffers_memory(camera: &Camera) -> u64 {
    let per_sample = std::mem::size_of::<Option<super::framebuffer::Hit>>() as u64 + 48 + 12 + 8;
    caoen_base::budget::bytes(camera.width.into(), camera.height.into(), per_sample)
}

/// What [`draw`] makes: the hit buffer, its statistics, each object's mesh when it was
/// drawn as one, and the budget reservations of those meshes.
type Drawn = (
    GBuffer,
    RenderStats,
    Vec<Option<Mesh>>,
    Vec<caoen_base::budget::Reservation>,
);

/// Draws every object into a nearest-hit buffer; also returns each object's mesh when
/// it was drawn as one, for the secondary rays to meet the same geometry.
fn draw(scene: &Scene, camera: &Camera, opts: &RenderOptions, prog: &Progress) -> Result<Drawn> {
    opts.limits.check(
        || format!("rendering {}x{} samples", camera.width, camera.height),
        buffers_memory(camera),
    )?;
    let mut buf = GBuffer::new(camera.width, camera.height);
    let mut stats = RenderStats::default();
    // Network camera: largest distance, their sum and the vertex count.
    let mut network_error = [0.0f64; 3];
    let mut meshes = Vec::with_capacity(scene.objects.len());
    // The meshes drawn so far stay for the secondary rays: every later check counts them.
    let mut held = Vec::new();
    for (oi, obj) in scene.objects.iter().enumerate() {
        let mut drawn = None;
        let id = oi as u32;
        match (&obj.shape, opts.method) {
            (
                Shape::Surface {
                    model,
                    place,
                    detail,
                },
                Method::Mesh,
            ) => {
                let mut mesh = tessellate(
                    model,
                    detail.unwrap_or(opts.mesh_detail),
                    opts.normals,
                    &opts.limits,
                )?;
                place_mesh(&mut mesh, place);
                if opts.network_camera {
                    let [max, sum, count] = network_projection(&mut mesh, model, place, camera)?;
                    network_error = [
                        network_error[0].max(max),
                        network_error[1] + sum,
                        network_error[2] + count,
                    ];
                }
                prog.within(1, 2);
                stats.triangles += rasterise(&mesh, camera, id, &mut buf);
                drawn = Some(mesh);
            }
            (Shape::Surface { model, place, .. }, _) => {
                let img =
                    depth_buffer(model, place, camera, &opts.depth, &|d, t| prog.within(d, t))?;
                stats.depth_samples += img.stats.samples;
                stats.unresolved += img.stats.unresolved;
                let hits = surface_hits(model, place, camera, opts.normals, &img.pixels, id)?;
                for (i, h) in hits.into_iter().enumerate() {
                    if let Some(h) = h {
                        buf.offer(i, h);
                    }
                }
            }
            (Shape::Solid { solids, csg }, Method::Mesh) => {
                let mesh = polygonise_solids(solids, csg, opts.polygonise_cells);
                prog.within(1, 2);
                stats.triangles += rasterise(&mesh, camera, id, &mut buf);
                drawn = Some(mesh);
            }
            (Shape::Field { node, bounds }, Method::Mesh) => {
                let mesh = caoen_frep::polygonise::render_mesh(node, bounds, opts.polygonise_cells);
                prog.within(1, 2);
                stats.triangles += rasterise(&mesh, camera, id, &mut buf);
                drawn = Some(mesh);
            }
            (Shape::Field { node, bounds }, _) => {
                let (hits, rays) = trace_field(node, bounds, camera, id, &|d, t| prog.within(d, t));
                stats.rays += rays;
                for (i, h) in hits.into_iter().enumerate() {
                    if let Some(h) = h {
                        buf.offer(i, h);
                    }
                }
            }
            (Shape::Solid { solids, csg }, _) => {
                let (hits, rays) = trace_solids(
                    &tracers(solids),
                    csg,
                    camera,
                    opts.ray_method,
                    id,
                    &|d, t| prog.within(d, t),
                );
                stats.rays += rays;
                for (i, h) in hits.into_iter().enumerate() {
                    if let Some(h) = h {
                        buf.offer(i, h);
                    }
                }
            }
        }
        if let Some(m) = &drawn {
            held.push(
                opts.limits
                    .reserve(|| format!("object {oi}'s mesh"), m.heap_bytes())?,
            );
        }
        meshes.push(drawn);
        prog.next();
    }
    if opts.network_camera {
        // Camera pixels per output pixel (supersampling).
        let per = f64::from(camera.width) / f64::from(opts.width);
        let [max, sum, count] = network_error;
        stats.projection_error = Some([max / per, sum / count.max(1.0) / per]);
    }
    Ok((buf, stats, meshes, held))
}

/// Moves every vertex of a placed mesh to where the paper's camera network puts it on
/// the screen (keeping its depth and normal) and returns `[max, sum, count]` of the
/// distances, in camera pixels, from where the exact camera puts it.
fn network_projection(
    mesh: &mut Mesh,
    model: &SurfaceModel,
    place: &caoen_geometry::transform::Affine,
    camera: &Camera,
) -> Result<[f64; 3]> {
    use super::camera::Projection;
    use caoen_surface::projection::{axis_generators, PerspectiveCamera};
    let net = &model.network;
    if net.output_dim() != 3 {
        return Err(RenderError::parameter(
            "network camera",
            "needs a surface with 3-D output",
        ));
    }
    // Placed shape vectors: an affine map commutes with a normalised network's convex
    // combination, so the placed network is the placed surface.
    let net = if place.is_identity() {
        net.clone()
    } else {
        if !net.is_normalised() {
            return Err(RenderError::parameter(
                "network camera",
                "a placed (transformed) surface must be normalised to move its shape vectors",
            ));
        }
        let shapes = net
            .shapes()
            .chunks_exact(3)
            .flat_map(|t| place.point([t[0], t[1], t[2]]))
            .collect();
        net.with_shapes(3, shapes)?
    };
    let domain: Vec<f64> = mesh.domain_points.iter().flatten().copied().collect();
    let mut moved = Vec::with_capacity(mesh.positions.len());
    match camera.projection {
        Projection::Perspective { .. } => {
            let f = camera.pixel_scale();
            let cam = PerspectiveCamera {
                eye: camera.eye,
                forward: camera.forward,
                right: camera.right,
                up: camera.up,
                focal: f,
            };
            let out = cam.approximate_network(&net)?.eval_batch(&domain)?;
            for s in out.chunks_exact(3) {
                let (u, v, d) = (s[0], s[1], s[2]);
                moved.push([0, 1, 2].map(|k| {
                    camera.eye[k]
                        + d * camera.forward[k]
                        + u * d / f * camera.right[k]
                        + v * d / f * camera.up[k]
                }));
            }
        }
        Projection::Orthographic { .. } => {
            // Three generators, along the camera's axes (formulas 14-15): exact.
            let axes: [&[f64]; 3] = [&camera.right, &camera.up, &camera.forward];
            let out = axis_generators(&net, &axes)?.eval_batch(&domain)?;
            for s in out.chunks_exact(3) {
                moved.push([0, 1, 2].map(|k| {
                    s[0] * camera.right[k] + s[1] * camera.up[k] + s[2] * camera.forward[k]
                }));
            }
        }
    }
    let (mut max, mut sum) = (0.0f64, 0.0);
    for (p, q) in mesh.positions.iter_mut().zip(moved) {
        if let (Some(a), Some(b)) = (camera.project(*p), camera.project(q)) {
            let e = (a[0] - b[0]).hypot(a[1] - b[1]);
            max = max.max(e);
            sum += e;
        }
        *p = q;
    }
    Ok([max, sum, mesh.positions.len() as f64])
}

/// Moves a mesh into the scene.
pub fn place_mesh(mesh: &mut Mesh, place: &Affine) {
    if place.is_identity() {
        return;
    }
    for p in &mut mesh.positions {
        *p = place.point(*p);
    }
    for nrm in &mut mesh.normals {
        *nrm = place.normal(*nrm);
    }
}

/// Turns depth-buffer samples into hits: each pixel's nearest sample is first moved
/// onto the ray through the pixel centre (a few Newton steps on the domain), so the
/// depth, normal and texture coordinates are those at the centre, as the rasteriser
/// and the ray tracer report them, rather than anywhere inside the pixel.
fn surface_hits(
    model: &SurfaceModel,
    place: &Affine,
    camera: &Camera,
    normals: NormalMode,
    pixels: &[Option<(f64, [f64; 4])>],
    object: u32,
) -> Result<Vec<Option<Hit>>> {
    let m = model.domain.ambient_dim();
    let nn = match normals {
        NormalMode::Interpolated => Some(NormalNetwork::new(&model.network, &model.domain)?),
        NormalMode::Exact => None,
    };
    let w = camera.width as usize;
    pixels
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let Some((depth, x)) = p else {
                return Ok(None);
            };
            let centre = [(i % w) as f64 + 0.5, (i / w) as f64 + 0.5];
            let (x, depth) = centre_sample(model, place, camera, &x[..m], *depth, centre)?;
            let n = match &nn {
                Some(nn) => nn.normal(&x)?,
                None => point_and_normal(&model.network, &model.domain, &x)?.1,
            };
            let n = place.normal(n);
            let uv = domain_uv(&model.domain, &x).map_or([f32::NAN; 2], |uv| uv.map(|v| v as f32));
            Ok(Some(Hit {
                depth,
                normal: n.map(|v| v as f32),
                uv,
                object,
            }))
        })
        .collect()
}

/// Moves the domain point `x` (whose image lies inside a pixel) so that its image lands
/// on the pixel centre; keeps `x` where the map is singular or a step would not help.
fn centre_sample(
    model: &SurfaceModel,
    place: &Affine,
    camera: &Camera,
    x: &[f64],
    depth: f64,
    centre: [f64; 2],
) -> Result<(Vec<f64>, f64)> {
    let (net, domain) = (&model.network, &model.domain);
    let mut best = (x.to_vec(), depth);
    let mut best_err = f64::INFINITY;
    let mut x = x.to_vec();
    for _ in 0..3 {
        let (y, jac) = net.eval_with_jacobian(&x)?;
        let p = place.point([y[0], y[1], y[2]]);
        let Some(s) = camera.project(p) else { break };
        let err = (s[0] - centre[0]).hypot(s[1] - centre[1]);
        if err >= best_err {
            break;
        }
        (best, best_err) = ((x.clone(), s[2]), err);
        if err < 1e-6 {
            break;
        }
        // Image-space derivatives along the domain's two tangents.
        let (ta, tb) = domain.tangents(&x)?;
        let sj = camera.screen_jacobian(p);
        let push = |t: &[f64; 4]| -> [f64; 2] {
            let mut d = [0.0; 3];
            for (g, dg) in d.iter_mut().enumerate() {
                *dg = (0..x.len()).map(|h| jac[g * x.len() + h] * t[h]).sum();
            }
            let d = place.point(d);
            let d = [d[0] - place.t[0], d[1] - place.t[1], d[2] - place.t[2]];
            [dot(sj[0], d), dot(sj[1], d)]
        };
        let (a, b) = (push(&ta), push(&tb));
        let det = a[0] * b[1] - b[0] * a[1];
        if !(det.abs() > 1e-12) {
            break;
        }
        let (ex, ey) = (centre[0] - s[0], centre[1] - s[1]);
        let da = (ex * b[1] - b[0] * ey) / det;
        let db = (a[0] * ey - ex * a[1]) / det;
        let step: Vec<f64> = (0..x.len())
            .map(|h| x[h] + da * ta[h] + db * tb[h])
            .collect();
        x = match domain.project(&step) {
            Ok(v) => v,
            Err(_) => break,
        };
    }
    // `best` starts as the original sample, so refinement never makes a pixel worse; a
    // step that slid onto another sheet of the surface would not get closer.
    Ok(best)
}

/// Ray casts an F-rep solid through every pixel of `camera` (interval subdivision,
/// normals from the exact gradient; a convex Cao En solid alone by its crossing
/// search); returns the hits and the number of rays.
pub fn trace_field(
    node: &caoen_frep::Node,
    bounds: &caoen_frep::Aabb,
    camera: &Camera,
    object: u32,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> (Vec<Option<Hit>>, usize) {
    if let Some(tracer) = super::rays::convex_solid(node) {
        let solid = [tracer.clone()];
        return super::csg::trace_solids(
            &solid,
            &super::csg::CsgNode::Solid(0),
            camera,
            caoen_surface::tracer::RayMethod::Fast,
            object,
            progress,
        );
    }
    let caster = caoen_frep::raycast::Caster::new(node, *bounds, Default::default());
    let (w, h) = (camera.width as usize, camera.height as usize);
    let hits = super::framebuffer::trace_rows(w, h, progress, |x, y, _: &mut ()| {
        let ray = camera.ray(x as f64 + 0.5, y as f64 + 0.5);
        let t = caster.first_hit(ray.origin, ray.dir, 0.0, f64::INFINITY)?;
        let p = ray.at(t);
        let (_, g) = node.value_gradient(p);
        let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        let k = if len > 0.0 { -1.0 / len } else { 0.0 };
        // Outward: the function decreases away from the solid.
        Some(Hit {
            depth: camera.depth(p),
            normal: g.map(|v| (k * v) as f32),
            uv: [f32::NAN; 2],
            object,
        })
    });
    (hits, w * h)
}

/// Shades every subpixel of `buf`, with shadow, reflected and refracted rays.
fn shade_buffer(
    scene: &Scene,
    camera: &Camera,
    buf: &GBuffer,
    rays: &RayScene,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> RgbImage {
    let w = buf.width as usize;
    let total = buf.hits.len() as u64;
    let done = AtomicU64::new(0);
    let pixels = buf
        .hits
        .par_iter()
        .enumerate()
        .inspect(|_| {
            // Reporting every sample would contend on the bar's lock.
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            if d.is_multiple_of(1024) {
                progress(d, total);
            }
        })
        .map(|(i, h)| match h {
            None => scene.background,
            Some(h) => {
                let obj = &scene.objects[h.object as usize];
                let ray = camera.ray((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
                // The hit point from its depth along the viewing direction.
                let along = dot(ray.dir, camera.forward);
                let t = (h.depth - dot(sub(ray.origin, camera.eye), camera.forward)) / along;
                let albedo = match (&obj.material.image_map, &obj.material.texture) {
                    _ if obj.material.checker.is_some() => obj.material.albedo_at(h.uv, ray.at(t)),
                    (Some(m), _) => m.colour(ray.at(t)),
                    (None, Some((_, wrap))) => obj
                        .material
                        .albedo_filtered(h.uv, uv_steps(buf, i, h, *wrap)),
                    (None, None) => obj.material.colour,
                };
                rays.shade(
                    ray.at(t),
                    ray.dir,
                    h.normal.map(|v| v as f64),
                    h.object,
                    albedo,
                    1,
                    1.0,
                    None,
                )
            }
        })
        .collect();
    RgbImage {
        width: buf.width,
        height: buf.height,
        pixels,
    }
}

/// How far the texture coordinates move per sample step in x and in y around sample
/// `i`: the smaller of the two one-sided differences to neighbours on the same object,
/// so a silhouette, an occluding edge or the texture's seam does not count as a
/// footprint; a wrapping coordinate's difference is taken the short way round.
fn uv_steps(buf: &GBuffer, i: usize, hit: &Hit, wrap: Wrap) -> [[f32; 2]; 2] {
    let (w, h) = (buf.width as usize, buf.height as usize);
    let (x, y) = (i % w, i / w);
    let (u_wraps, v_wraps) = match wrap {
        Wrap::Sphere => (true, false),
        Wrap::Torus => (true, true),
        Wrap::Clamp => (false, false),
    };
    let diff = |j: usize| -> Option<[f32; 2]> {
        let n = buf.hits[j].as_ref()?;
        if n.object != hit.object || !n.uv[0].is_finite() {
            return None;
        }
        let short = |d: f32, wraps: bool| if wraps { d - d.round() } else { d };
        Some([
            short(n.uv[0] - hit.uv[0], u_wraps),
            short(n.uv[1] - hit.uv[1], v_wraps),
        ])
    };
    let len = |d: &[f32; 2]| d[0].hypot(d[1]);
    let pick = |a: Option<[f32; 2]>, b: Option<[f32; 2]>| match (a, b) {
        (Some(a), Some(b)) => {
            if len(&a) <= len(&b) {
                a
            } else {
                b
            }
        }
        (Some(a), None) | (None, Some(a)) => a,
        (None, None) => [0.0; 2],
    };
    let dx = pick(
        (x > 0).then(|| diff(i - 1)).flatten(),
        (x + 1 < w).then(|| diff(i + 1)).flatten(),
    );
    let dy = pick(
        (y > 0).then(|| diff(i - w)).flatten(),
        (y + 1 < h).then(|| diff(i + w)).flatten(),
    );
    [dx, dy]
}
