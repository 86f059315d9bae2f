//! The graph runs of one build: every run (trial runs of the searches, then the final one)
//! uses the same cache, options and observer, and adds to the same per-stage counts.

use ori_graph::{Build, Cache, Graph, Observer, RunOptions};

use crate::summary::StageLine;

pub struct Runs<'a> {
    pub cache: Cache,
    pub options: RunOptions,
    pub observer: &'a dyn Observer,
    /// Per stage, over every run so far.
    pub stages: Vec<StageLine>,
}

impl<'a> Runs<'a> {
    /// Run `graph` and count what it did.
    pub fn run<'g>(&mut self, graph: &'g Graph) -> Build<'g>
    where
        'a: 'g,
    {
        let build = ori_graph::run(graph, &self.cache, &self.options, self.observer);
        StageLine::add_run(&mut self.stages, &build);
        build
    }
}
