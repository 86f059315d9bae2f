//! Measuring techniques against the mesh: the evaluator's views, reference and errors, for
//! every technique in each view (the mesh is rendered once per view).

use ori_bake::Baker;
use ori_eval::{Mask, MeshCoverage, Render, ShadedMesh, Shading, ViewErrors, eval_view};
use ori_mesh::Mesh;
use ori_raster::OrthoView;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::{Drawn, Primitive, Rival, RivalError, Technique};

/// The mesh's coverage at the tuning directions, to choose a technique's layout by.
pub struct References {
    views: Vec<OrthoView>,
    coverage: Vec<Mask>,
}

impl References {
    pub fn new(mesh: &Mesh, directions: &[[f64; 3]], s0: u32) -> Result<References, RivalError> {
        let views = directions
            .iter()
            .map(|&w| eval_view(mesh, w, s0))
            .collect::<Result<Vec<_>, _>>()?;
        let mesh = MeshCoverage::new(mesh);
        let coverage = views.par_iter().map(|v| mesh.of(v)).collect();
        Ok(References { views, coverage })
    }

    /// The directions of the tuning views (towards the viewer).
    pub fn directions(&self) -> Vec<[f64; 3]> {
        self.views.iter().map(|v| v.frame.d).collect()
    }

    /// The silhouette error of `rival` (pixels of the mesh it misses plus pixels it adds),
    /// summed over the views: what layouts are chosen by, so that neither fat nor thin
    /// silhouettes are favoured.
    pub fn silhouette_error(&self, rival: &dyn Rival) -> Result<u64, RivalError> {
        let errors = self
            .views
            .par_iter()
            .zip(&self.coverage)
            .map(|(v, mesh)| {
                let drawn = rival.draw(v)?.render.coverage;
                Ok(u64::from(mesh.count_minus(&drawn)) + u64::from(drawn.count_minus(mesh)))
            })
            .collect::<Result<Vec<u64>, RivalError>>()?;
        Ok(errors.iter().sum())
    }
}

/// One view of one technique.
#[derive(Clone, Copy, Debug)]
pub struct Measured {
    pub errors: ViewErrors,
    /// Quads or triangles drawn.
    pub drawn: u32,
    /// How long drawing took (for progress reports; not part of any result).
    pub time: std::time::Duration,
}

/// A technique's figures over the directions measured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    pub technique: Technique,
    pub bytes: u64,
    /// The layout the technique chose for the budget, in words.
    pub layout: String,
    pub coverage_error_avg_percent: f64,
    pub coverage_error_max_percent: f64,
    pub inverse_coverage_avg_percent: f64,
    pub p_dif_avg: f64,
    /// Mean |depth difference| over the pixels both cover, as a fraction of the object's
    /// extent along the view.
    pub depth_error_avg: f64,
    /// Mean quads or triangles drawn per view.
    pub drawn_per_view: f64,
    /// What `drawn_per_view` counts.
    pub drawn: Primitive,
}

/// The result of `cargo xtask compare`: the JSON file `--json` writes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    pub model: String,
    pub budget_bytes: u64,
    pub held_out_seed: u64,
    /// Directions measured.
    pub directions: usize,
    pub s0: u32,
    pub rows: Vec<Row>,
}

/// Every technique at every direction: `[direction][technique]`.
pub fn measure(
    mesh: &Mesh,
    rivals: &[&dyn Rival],
    directions: &[[f64; 3]],
    s0: u32,
) -> Result<Vec<Vec<Measured>>, RivalError> {
    let baker = Baker::new(mesh);
    directions
        .par_iter()
        .map(|&w| {
            let view = eval_view(mesh, w, s0)?;
            let reference = ori_eval::render_mesh(&baker, &view)?;
            let shaded = ShadedMesh::new(&view, &reference);
            rivals
                .iter()
                .map(|r| {
                    let started = std::time::Instant::now();
                    let drawn = match r.draws_the_mesh() {
                        Some(count) => Drawn {
                            render: reference.clone(),
                            count,
                        },
                        None => r.draw(&view)?,
                    };
                    let time = started.elapsed();
                    Ok(Measured {
                        errors: shaded.compare(&drawn.render),
                        drawn: drawn.count,
                        time,
                    })
                })
                .collect()
        })
        .collect()
}

/// Measure `rivals` at `directions` and sum each up (rows in the order of `rivals`).
pub fn compare(
    mesh: &Mesh,
    rivals: &[&dyn Rival],
    directions: &[[f64; 3]],
    s0: u32,
) -> Result<Vec<Row>, RivalError> {
    Ok(summarize(rivals, &measure(mesh, rivals, directions, s0)?))
}

/// Sum up the views of [`measure`] (rows in the order of `rivals`).
pub fn summarize(rivals: &[&dyn Rival], per_view: &[Vec<Measured>]) -> Vec<Row> {
    let n = per_view.len().max(1) as f64;
    rivals
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let views = per_view.iter().map(|v| v[k]);
            let sum = |f: &dyn Fn(&Measured) -> f64| views.clone().map(|m| f(&m)).sum::<f64>();
            Row {
                technique: r.technique(),
                bytes: r.bytes(),
                layout: r.layout(),
                coverage_error_avg_percent: sum(&|m| m.errors.missed_percent()) / n,
                coverage_error_max_percent: views
                    .clone()
                    .map(|m| m.errors.missed_percent())
                    .fold(0.0, f64::max),
                inverse_coverage_avg_percent: sum(&|m| m.errors.extra_percent()) / n,
                p_dif_avg: sum(&|m| m.errors.p_dif) / n,
                depth_error_avg: sum(&|m| m.errors.depth_error) / n,
                drawn_per_view: sum(&|m| f64::from(m.drawn)) / n,
                drawn: r.primitive(),
            }
        })
        .collect()
}

/// The shaded image of a render (background black), RGB rows from the top.
fn shaded(view: &OrthoView, render: &Render) -> Vec<u8> {
    let shading = Shading::new(view);
    let n = render.size as usize * render.size as usize;
    (0..n)
        .flat_map(|i| {
            if render.coverage.get(i) {
                shading.shade(render.albedo[i], render.normal[i])
            } else {
                [0; 3]
            }
        })
        .collect()
}

/// One view of the mesh and of every technique side by side (the mesh first), as RGB:
/// `(width, height, pixels)`.
pub fn picture(
    mesh: &Mesh,
    rivals: &[&dyn Rival],
    w: [f64; 3],
    s0: u32,
) -> Result<(u32, u32, Vec<u8>), RivalError> {
    let view = eval_view(mesh, w, s0)?;
    let reference = ori_eval::render_mesh(&Baker::new(mesh), &view)?;
    let mut panels = vec![shaded(&view, &reference)];
    for r in rivals {
        panels.push(shaded(&view, &r.draw(&view)?.render));
    }
    let (n, count) = (s0 as usize, panels.len());
    let mut rgb = Vec::with_capacity(3 * n * n * count);
    for y in 0..n {
        for panel in &panels {
            rgb.extend_from_slice(&panel[3 * y * n..3 * (y + 1) * n]);
        }
    }
    Ok(((n * count) as u32, s0, rgb))
}
