//! A hierarchy package on the GPU: every node's ORI, drawn by the runtime traversal
//! (`ori_hierarchy::traverse`) with option 5 between and within nodes.

use ori_hierarchy::Visit;
use ori_package::{Hierarchy, HierarchyManifest};

use crate::{Camera, Draw, GpuMesh, GpuOri, Priority, RenderError, Renderer};

/// A hierarchy ready to draw: made by [`Renderer::load_hierarchy`].
pub struct GpuHierarchy {
    tree: HierarchyManifest,
    nodes: Vec<GpuOri>,
}

impl Renderer {
    /// Upload every node's ORI of a hierarchy package. Each node draws with option 5
    /// ([`Priority::BiasedDepth`]): the rule between hierarchy nodes, whose ORIs overlap where
    /// their inflated cells do.
    pub fn load_hierarchy(&self, hierarchy: &Hierarchy) -> Result<GpuHierarchy, RenderError> {
        let mut nodes = Vec::with_capacity(hierarchy.nodes.len());
        for (i, package) in hierarchy.nodes.iter().enumerate() {
            let mut ori = self
                .load_package(package)
                .map_err(|e| RenderError::Package(format!("node {i}: {e}")))?;
            ori.set_priority(Priority::BiasedDepth);
            nodes.push(ori);
        }
        Ok(GpuHierarchy {
            tree: hierarchy.manifest.clone(),
            nodes,
        })
    }
}

impl GpuHierarchy {
    /// The tree.
    pub fn tree(&self) -> &HierarchyManifest {
        &self.tree
    }

    /// Node `i`'s ORI.
    pub fn node(&self, i: usize) -> &GpuOri {
        &self.nodes[i]
    }

    /// What the runtime draws for `camera` in an image `height` pixels high: the traversal
    /// with each node's bounding sphere projected by the camera.
    pub fn traverse(&self, camera: &Camera, height: u32) -> Vec<Visit> {
        ori_hierarchy::traverse(&self.tree, |i| self.nodes[i].manifest(), &|c, r| {
            camera.projected_sphere_edge(c, r, height)
        })
    }

    /// The draw list of `visits`: node ORIs, and for [`Visit::Mesh`] the leaf's mesh from
    /// `meshes[node]` (the model clipped to the node's cell; the package holds no mesh). A
    /// mesh visit without a mesh is an error.
    pub fn draws<'a>(
        &'a self,
        visits: &[Visit],
        meshes: &'a [Option<GpuMesh>],
    ) -> Result<Vec<Draw<'a>>, RenderError> {
        visits
            .iter()
            .map(|&v| match v {
                Visit::Ori(i) => Ok(Draw::Ori(&self.nodes[i])),
                Visit::Mesh(i) => meshes
                    .get(i)
                    .and_then(Option::as_ref)
                    .map(Draw::Mesh)
                    .ok_or_else(|| {
                        RenderError::Scene(format!("leaf {i} is past its PLT and has no mesh"))
                    }),
            })
            .collect()
    }
}
