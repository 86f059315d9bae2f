//! Relief maps drawn with the ORI's runtime rule: the `relief-box` of seed 003 (six
//! axis-aligned relief textures, the facing ones drawn, closest direction first) and the ORI
//! itself (its selection table's subset).

use ori_bake::BakeParams;
use ori_eval::{EvalParams, Evaluator};
use ori_mesh::Mesh;
use ori_raster::OrthoView;
use ori_relief::ReliefSet;
use ori_select::Selection;

use crate::{Drawn, Primitive, Rival, RivalError, Technique, relief_bytes, within_budget};

/// The subset of impostors a view direction draws.
pub type Subsets<'a> = Box<dyn Fn([f64; 3]) -> Vec<usize> + Send + Sync + 'a>;

/// Which impostors a view draws.
enum Rule<'a> {
    /// Every facing one, closest direction first.
    Facing,
    /// A selection table's.
    Table(Subsets<'a>),
}

/// Relief maps drawn by the runtime rule.
pub struct Relief<'a> {
    technique: Technique,
    evaluator: Evaluator<'a>,
    rule: Rule<'a>,
}

impl<'a> Relief<'a> {
    /// The six axis maps with the largest edge (a multiple of 4 texels, whole BC blocks)
    /// within `budget`.
    pub fn bake_box(mesh: &Mesh, budget: u64) -> Result<ReliefSet, RivalError> {
        let technique = Technique::ReliefBox.name();
        let bytes = |r: u32| relief_bytes(6 * u64::from(r) * u64::from(r));
        let r = crate::edge_for(budget, 6, 4, relief_bytes).unwrap_or(4);
        if !within_budget(bytes(r), budget) || r < 8 {
            return Err(RivalError::Budget {
                technique,
                budget,
                closest: bytes(r),
            });
        }
        let params = BakeParams {
            resolution: r,
            ..BakeParams::default()
        };
        ori_bake::bake_any_resolution(mesh, &ori_views::axis_directions(), &params).map_err(|e| {
            RivalError::Bake {
                technique,
                reason: e.to_string(),
            }
        })
    }

    /// The relief box of `maps` (from [`Relief::bake_box`]), drawn with the default
    /// runtime parameters.
    pub fn relief_box(mesh: &'a Mesh, maps: &'a ReliefSet) -> Result<Relief<'a>, RivalError> {
        Ok(Relief {
            technique: Technique::ReliefBox,
            evaluator: Evaluator::new(mesh, maps, &EvalParams::default())?,
            rule: Rule::Facing,
        })
    }

    /// The ORI of `maps` and `selection`, drawn with the evaluation parameters `params`.
    pub fn ori(
        mesh: &'a Mesh,
        maps: &'a ReliefSet,
        selection: &'a Selection,
        params: &EvalParams,
    ) -> Result<Relief<'a>, RivalError> {
        let subsets = |w: [f64; 3]| {
            let entry = selection.lookup(w);
            entry.impostors.iter().map(|&i| usize::from(i)).collect()
        };
        Relief::ori_with(mesh, maps, Box::new(subsets), params)
    }

    /// The ORI of `maps` whose table gives `subsets` (a package's, read as a runtime does).
    pub fn ori_with(
        mesh: &'a Mesh,
        maps: &'a ReliefSet,
        subsets: Subsets<'a>,
        params: &EvalParams,
    ) -> Result<Relief<'a>, RivalError> {
        Ok(Relief {
            technique: Technique::Ori,
            evaluator: Evaluator::new(mesh, maps, params)?,
            rule: Rule::Table(subsets),
        })
    }

    fn subset(&self, w: [f64; 3]) -> Vec<usize> {
        match &self.rule {
            Rule::Facing => self.evaluator.facing(w),
            Rule::Table(subsets) => subsets(w),
        }
    }
}

impl Rival for Relief<'_> {
    fn technique(&self) -> Technique {
        self.technique
    }

    fn bytes(&self) -> u64 {
        let maps = &self.evaluator.set().maps;
        relief_bytes(maps.iter().map(|m| u64::from(m.size()).pow(2)).sum())
    }

    fn layout(&self) -> String {
        let maps = &self.evaluator.set().maps;
        let r = maps[0].size();
        format!("{} relief maps of {r} x {r}", maps.len())
    }

    fn primitive(&self) -> Primitive {
        Primitive::Quads
    }

    fn draw(&self, view: &OrthoView) -> Result<Drawn, RivalError> {
        let subset = self.subset(view.frame.d);
        Ok(Drawn {
            render: self.evaluator.render_ori(view, &subset),
            count: subset.len() as u32,
        })
    }
}
