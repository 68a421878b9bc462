//! Incremental mode (paper section 5.5): after a material or geometry change, the links are brought
//! up to date a bounded amount of form-factor work per frame, instead of relinking from scratch.
//!
//! A material change marks every link stale; a geometry change (a [`RefitReport`]) marks the links
//! whose receiver or source has a moved vertex below it. Each [`IncrementalLinks::step`] takes stale
//! or newly made links off a queue and, per link (R, E), asks the oracle again:
//! - it wants R or E split: the link moves one level down (two children links, two form factors;
//!   the children are queued in turn, so a link sinks as far as needed over several steps);
//! - it accepts the link and also the coarser (parent(R), E) whose other child holds the sibling
//!   link (or (R, parent(E)) likewise): the two links move one level up into one (Forsyth et al.
//!   1994's demotion), queued again;
//! - otherwise its form factor is recomputed if stale.
//!
//! Every move keeps the links a partition of receiver x emitter leaf pairs, so the exitance stays
//! complete while the queue drains; it just uses some old form factors until then.
//!
//! ```
//! use translucent::material::Material;
//! use translucent::mesh::shapes::Shape;
//! use translucent::solver::dipole::{BoundaryModel, DipoleProfile, FaceClusterHierarchy, IncrementalLinks, LinkParams};
//! let mesh = Shape::Sphere { radius: 10.0 }.triangulate(10);
//! let (tree, _) = FaceClusterHierarchy::build(&mesh)?;
//! let marble = DipoleProfile::new(&Material::preset("marble")?, BoundaryModel::Moments);
//! let mut links = IncrementalLinks::new(&tree, &marble, &LinkParams::default());
//! let wax = DipoleProfile::new(&Material::preset("skin2")?, BoundaryModel::Moments);
//! links.material_changed(wax);
//! while links.pending() > 0 {
//!     let report = links.step(&tree, 500); // at most ~500 form factors per frame
//!     assert!(report.form_factors <= 500 + 2);
//! }
//! let set = links.link_set(); // upload to the GPU gather
//! # let _ = set;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::collections::VecDeque;

use super::hierarchy::{FaceClusterHierarchy, RefitReport, NO_NODE};
use super::links::{decide, form_factor, Decision, Link, LinkParams, LinkSet, LinkStats};
use super::profile::DipoleProfile;

/// What one [`IncrementalLinks::step`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepReport {
    /// Form factors computed (the bounded work).
    pub form_factors: u64,
    /// Links moved one level down (split).
    pub promoted: u64,
    /// Link pairs moved one level up (merged).
    pub demoted: u64,
    /// Links whose form factor was recomputed in place.
    pub updated: u64,
    /// Queue entries left.
    pub pending: usize,
}

/// One link with the generation of its form factor.
#[derive(Clone, Copy, Debug)]
struct Entry {
    link: Link,
    evaluated: u32,
}

/// Links kept per receiver, with a queue of links to revisit (module doc).
pub struct IncrementalLinks {
    by_receiver: Vec<Vec<Entry>>,
    /// (receiver, source, generation queued at).
    queue: VecDeque<(u32, u32, u32)>,
    generation: u32,
    profile: DipoleProfile,
    params: LinkParams,
    count: usize,
    stats: LinkStats,
}

impl IncrementalLinks {
    /// Links `tree` from scratch ([`LinkSet::build`]) and keeps them for incremental updates.
    pub fn new(
        tree: &FaceClusterHierarchy,
        profile: &DipoleProfile,
        params: &LinkParams,
    ) -> IncrementalLinks {
        let (set, stats) = LinkSet::build(tree, profile, params);
        let mut by_receiver: Vec<Vec<Entry>> = vec![Vec::new(); tree.nodes.len()];
        for (r, list) in by_receiver.iter_mut().enumerate() {
            *list = set
                .of(r as u32)
                .iter()
                .map(|&link| Entry { link, evaluated: 0 })
                .collect();
        }
        IncrementalLinks {
            by_receiver,
            queue: VecDeque::new(),
            generation: 0,
            profile: *profile,
            params: *params,
            count: set.len(),
            stats,
        }
    }

    /// Keeps `set` (made by [`LinkSet::build`] with `profile` and `params`, counters `stats`) for
    /// incremental updates, without linking again.
    pub fn from_set(
        set: &LinkSet,
        profile: &DipoleProfile,
        params: &LinkParams,
        stats: LinkStats,
    ) -> IncrementalLinks {
        let by_receiver = (0..set.receiver_offsets.len().saturating_sub(1))
            .map(|r| {
                set.of(r as u32)
                    .iter()
                    .map(|&link| Entry { link, evaluated: 0 })
                    .collect()
            })
            .collect();
        IncrementalLinks {
            by_receiver,
            queue: VecDeque::new(),
            generation: 0,
            profile: *profile,
            params: *params,
            count: set.len(),
            stats,
        }
    }

    /// The counters of the initial linking.
    pub fn build_stats(&self) -> &LinkStats {
        &self.stats
    }

    /// Number of links.
    pub fn len(&self) -> usize {
        self.count
    }

    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Queue entries still to visit.
    pub fn pending(&self) -> usize {
        self.queue.len()
    }

    /// A new material: every link is stale.
    pub fn material_changed(&mut self, profile: DipoleProfile) {
        self.profile = profile;
        self.generation += 1;
        let g = self.generation;
        for (r, list) in self.by_receiver.iter().enumerate() {
            for e in list {
                self.queue.push_back((r as u32, e.link.source, g));
            }
        }
    }

    /// The vertices moved (the tree was refitted): links touching a changed node are stale.
    pub fn geometry_changed(&mut self, report: &RefitReport) {
        self.generation += 1;
        let g = self.generation;
        for (r, list) in self.by_receiver.iter().enumerate() {
            let r_changed = report.changed.get(r).copied().unwrap_or(true);
            for e in list {
                let s = e.link.source as usize;
                if r_changed || report.changed.get(s).copied().unwrap_or(true) {
                    self.queue.push_back((r as u32, e.link.source, g));
                }
            }
        }
    }

    fn find(&self, r: u32, e: u32) -> Option<usize> {
        self.by_receiver[r as usize]
            .iter()
            .position(|x| x.link.source == e)
    }

    fn remove(&mut self, r: u32, e: u32) {
        if let Some(i) = self.find(r, e) {
            self.by_receiver[r as usize].swap_remove(i);
            self.count -= 1;
        }
    }

    /// Adds the link (r, e) with a fresh form factor and queues it for an oracle check.
    fn insert(&mut self, tree: &FaceClusterHierarchy, r: u32, e: u32, report: &mut StepReport) {
        let mut s = LinkStats::default();
        let f = form_factor(tree, &self.profile, &self.params, r, e, &mut s);
        report.form_factors += 1;
        self.by_receiver[r as usize].push(Entry {
            link: Link {
                form_factor: f.map(|v| v as f32),
                source: e,
            },
            evaluated: self.generation,
        });
        self.count += 1;
        self.queue.push_back((r, e, self.generation));
    }

    /// The sibling of `n` (the other child of its parent), if it has a parent.
    fn sibling(tree: &FaceClusterHierarchy, n: u32) -> Option<(u32, u32)> {
        let p = tree.nodes[n as usize].parent;
        if p == NO_NODE {
            return None;
        }
        let [a, b] = tree.nodes[p as usize].children;
        Some((p, if a == n { b } else { a }))
    }

    /// Visits queued links until about `budget` form factors were computed (at least one link is
    /// visited; a split may exceed the budget by one form factor).
    pub fn step(&mut self, tree: &FaceClusterHierarchy, budget: u64) -> StepReport {
        let mut report = StepReport::default();
        while report.form_factors < budget.max(1) {
            let Some((r, e, queued)) = self.queue.pop_front() else {
                break;
            };
            let Some(i) = self.find(r, e) else {
                continue; // moved or merged since it was queued
            };
            match decide(tree, &self.profile, &self.params, r, e) {
                Decision::SplitReceiver => {
                    self.remove(r, e);
                    for c in tree.nodes[r as usize].children {
                        self.insert(tree, c, e, &mut report);
                    }
                    report.promoted += 1;
                }
                Decision::SplitEmitter => {
                    self.remove(r, e);
                    for c in tree.nodes[e as usize].children {
                        self.insert(tree, r, c, &mut report);
                    }
                    report.promoted += 1;
                }
                Decision::Link => {
                    let up_receiver = Self::sibling(tree, r).filter(|&(p, s)| {
                        self.find(s, e).is_some()
                            && decide(tree, &self.profile, &self.params, p, e) == Decision::Link
                    });
                    let up_emitter = || {
                        Self::sibling(tree, e).filter(|&(p, s)| {
                            self.find(r, s).is_some()
                                && decide(tree, &self.profile, &self.params, r, p) == Decision::Link
                        })
                    };
                    if let Some((p, s)) = up_receiver {
                        self.remove(r, e);
                        self.remove(s, e);
                        self.insert(tree, p, e, &mut report);
                        report.demoted += 1;
                    } else if let Some((p, s)) = up_emitter() {
                        self.remove(r, e);
                        self.remove(r, s);
                        self.insert(tree, r, p, &mut report);
                        report.demoted += 1;
                    } else if self.by_receiver[r as usize][i].evaluated < queued {
                        let mut s = LinkStats::default();
                        let f = form_factor(tree, &self.profile, &self.params, r, e, &mut s);
                        let entry = &mut self.by_receiver[r as usize][i];
                        entry.link.form_factor = f.map(|v| v as f32);
                        entry.evaluated = self.generation;
                        report.form_factors += 1;
                        report.updated += 1;
                    }
                }
            }
        }
        report.pending = self.queue.len();
        report
    }

    /// The links in the GPU's CSR form.
    pub fn link_set(&self) -> LinkSet {
        let pairs = self
            .by_receiver
            .iter()
            .enumerate()
            .flat_map(|(r, list)| list.iter().map(move |e| (r as u32, e.link)))
            .collect();
        LinkSet::from_pairs(self.by_receiver.len(), pairs)
    }
}
