//! The background lattice that isosurface stuffing cuts: a body-centred cubic (BCC) lattice, uniform
//! near the surface and graded by a balanced octree away from it (Labelle and Shewchuk 2007, sections
//! 2 and 5).
//!
//! Lattice vertices are the corners and centres of the octree's leaf cubes. Tetrahedra come from the
//! faces between leaves:
//! - two leaves of the same size sharing a face give one BCC tetrahedron per face edge (the two cube
//!   centres and the edge), or two "half" tetrahedra when a smaller leaf elsewhere put a vertex at the
//!   edge's midpoint;
//! - a leaf beside a leaf twice its size gives one transition tetrahedron per edge of its face (its
//!   centre, the big leaf's centre and the edge).
//!
//! With the octree balanced (leaves sharing a face, edge or corner differ at most 2x in size) these
//! tetrahedra fill the octree's leaves exactly and conform face to face. Every leaf within
//! [`FINE_BAND_CELLS`] fine cells of the surface has the finest size, so the tetrahedra that the
//! stuffing cuts are uniform BCC tetrahedra and keep the uniform lattice's angle bounds.
//!
//! ```
//! use glam::DVec3;
//! use translucent::tet::lattice::{BccLattice, LatticeParams};
//! // A lattice around a unit box whose surface passes through the point (0.5, 0, 0).
//! let params = LatticeParams { spacing: 0.25, grading: 0.0 };
//! let lattice = BccLattice::build(&params, (DVec3::splat(-0.5), DVec3::splat(0.5)), &[DVec3::new(0.5, 0.0, 0.0)]);
//! assert!(lattice.tets.len() > 0);
//! ```

use std::collections::{HashMap, HashSet, VecDeque};

use glam::{DVec3, IVec3};

use crate::limits::{Limit, LimitExceeded};

/// Leaves within this many fine cells (Chebyshev distance) of a cell holding a surface sample have
/// the finest size. Every point of the surface lies within one cell of a sample, so the lattice
/// tetrahedra the surface cuts are finest BCC ones; [`crate::tet::stuffing::StuffStats::coarse_cut_tets`]
/// counts any that are not (none on the test shapes and meshes; see the bake tests). A band of 2
/// would also cover every tetrahedron around a warped vertex, at 16-18% more inner nodes (measured
/// on spot and the bunny) for no change in the measured angles.
pub const FINE_BAND_CELLS: u16 = 1;

/// How the lattice is laid out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LatticeParams {
    /// Edge length of the finest cubes in mm (the lattice spacing `h`; BCC long edges have length `h`).
    pub spacing: f64,
    /// Grading `K` (paper section 4.1): a leaf of `S` fine cells inside the solid is allowed only at
    /// Chebyshev distance `>= S / K` fine cells from the surface. `0` gives a uniform interior;
    /// above 1 the 2:1 balance of the octree limits the grading, so values above 1 act as 1.
    pub grading: f64,
}

/// One lattice vertex: a cube corner or a cube centre.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LatticeVertexKind {
    Corner,
    Centre,
}

/// The graded BCC lattice: vertices and positively oriented tetrahedra.
#[derive(Clone, Debug, Default)]
pub struct BccLattice {
    pub vertices: Vec<DVec3>,
    /// Integer coordinates in half fine cells.
    pub coords: Vec<IVec3>,
    pub kinds: Vec<LatticeVertexKind>,
    pub tets: Vec<[u32; 4]>,
    /// Whether tetrahedron `t` is a uniform BCC tetrahedron of the finest size.
    pub finest: Vec<bool>,
    /// The finest spacing in mm.
    pub spacing: f64,
    /// Number of octree leaves per size exponent (0: finest).
    pub leaves_per_size: Vec<usize>,
}

/// An octree cell: size exponent and minimum corner in fine cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct Cell {
    level: u8,
    min: IVec3,
}

impl Cell {
    fn size(self) -> i32 {
        1 << self.level
    }
    fn children(self) -> [Cell; 8] {
        let h = self.size() / 2;
        std::array::from_fn(|i| Cell {
            level: self.level - 1,
            min: self.min
                + IVec3::new((i & 1) as i32, ((i >> 1) & 1) as i32, ((i >> 2) & 1) as i32) * h,
        })
    }
}

/// Fine-cell distance field to the surface, with a min pyramid for block queries.
struct DistanceGrid {
    /// Per level: dims and the min distance over all, interior and exterior cells of each block.
    pyramid: Vec<(IVec3, [Vec<u16>; 3])>,
}

impl DistanceGrid {
    /// Chebyshev distance (in fine cells) from each cell to the nearest cell holding a surface
    /// sample, and whether the cell is reachable from the grid border without crossing the surface
    /// (exterior). With holes in the surface the flood leaks inside; that only coarsens more there.
    fn new(dims: IVec3, seeds: &[IVec3], levels: u8) -> Self {
        let n = (dims.x * dims.y * dims.z) as usize;
        let index = |p: IVec3| ((p.z * dims.y + p.y) * dims.x + p.x) as usize;
        let inside = |p: IVec3| (p.cmpge(IVec3::ZERO) & p.cmplt(dims)).all();
        let mut dist = vec![u16::MAX; n];
        let mut queue = VecDeque::new();
        for &s in seeds {
            if inside(s) && dist[index(s)] != 0 {
                dist[index(s)] = 0;
                queue.push_back(s);
            }
        }
        while let Some(p) = queue.pop_front() {
            let d = dist[index(p)] + 1;
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let q = p + IVec3::new(dx, dy, dz);
                        if inside(q) && dist[index(q)] > d {
                            dist[index(q)] = d;
                            queue.push_back(q);
                        }
                    }
                }
            }
        }
        // Exterior: 6-connected flood from the border. Every cell the surface touches lies within one
        // cell of a sample (samples are at most half a cell apart), so cells at distance <= 1 seal it.
        let mut exterior = vec![false; n];
        let mut queue = VecDeque::new();
        for z in 0..dims.z {
            for y in 0..dims.y {
                for x in 0..dims.x {
                    let p = IVec3::new(x, y, z);
                    let border = (p.cmpeq(IVec3::ZERO) | p.cmpeq(dims - 1)).any();
                    if border && dist[index(p)] > 1 && !exterior[index(p)] {
                        exterior[index(p)] = true;
                        queue.push_back(p);
                    }
                }
            }
        }
        while let Some(p) = queue.pop_front() {
            for q in [
                IVec3::X,
                IVec3::NEG_X,
                IVec3::Y,
                IVec3::NEG_Y,
                IVec3::Z,
                IVec3::NEG_Z,
            ]
            .map(|d| p + d)
            {
                if inside(q) && dist[index(q)] > 1 && !exterior[index(q)] {
                    exterior[index(q)] = true;
                    queue.push_back(q);
                }
            }
        }
        let interior: Vec<u16> = dist
            .iter()
            .zip(&exterior)
            .map(|(&d, &e)| if e { u16::MAX } else { d })
            .collect();
        let outside: Vec<u16> = dist
            .iter()
            .zip(&exterior)
            .map(|(&d, &e)| if e { d } else { u16::MAX })
            .collect();
        let mut pyramid = vec![(dims, [dist, interior, outside])];
        for _ in 0..levels {
            let (d, fields) = pyramid.last().expect("pyramid starts with the fine grid");
            let nd = (*d + 1) / 2;
            let mut next: [Vec<u16>; 3] =
                std::array::from_fn(|_| vec![u16::MAX; (nd.x * nd.y * nd.z) as usize]);
            for z in 0..d.z {
                for y in 0..d.y {
                    for x in 0..d.x {
                        let src = ((z * d.y + y) * d.x + x) as usize;
                        let dst = (((z / 2) * nd.y + y / 2) * nd.x + x / 2) as usize;
                        for (n, f) in next.iter_mut().zip(fields) {
                            n[dst] = n[dst].min(f[src]);
                        }
                    }
                }
            }
            pyramid.push((nd, next));
        }
        Self { pyramid }
    }

    /// Min distance over all, interior and exterior fine cells of a cell; `MAX` outside the grid.
    fn block_min(&self, cell: Cell) -> [u16; 3] {
        let (d, fields) = &self.pyramid[cell.level as usize];
        let p = cell.min / cell.size();
        if (p.cmplt(IVec3::ZERO) | p.cmpge(*d)).any() {
            return [u16::MAX; 3];
        }
        let i = ((p.z * d.y + p.y) * d.x + p.x) as usize;
        fields.each_ref().map(|f| f[i])
    }
}

impl BccLattice {
    /// Builds the lattice over `bounds` (padded by a few cells) so that every leaf within
    /// [`FINE_BAND_CELLS`] of a `surface_samples` point has the finest size. Surface samples should be
    /// no farther apart than half the spacing (see [`sample_surface`]).
    pub fn build(
        params: &LatticeParams,
        bounds: (DVec3, DVec3),
        surface_samples: &[DVec3],
    ) -> Self {
        // Without a limit nothing can be refused.
        Self::build_limited(params, bounds, surface_samples, u64::MAX).unwrap_or_default()
    }

    /// [`BccLattice::build`], refused with [`Limit::LatticeNodes`] when the lattice would have more
    /// than `max_nodes` nodes. The estimate, twice the octree's leaves (a leaf brings its centre
    /// and, shared with its neighbours, about one corner), is counted by a walk of the octree that
    /// stores nothing, before the leaves and the lattice are allocated. The fine distance grid the
    /// walk needs is bounded by the spacing (the bake's resolution, at most 512 cells across).
    pub fn build_limited(
        params: &LatticeParams,
        bounds: (DVec3, DVec3),
        surface_samples: &[DVec3],
        max_nodes: u64,
    ) -> Result<Self, LimitExceeded> {
        let h = params.spacing;
        let margin = FINE_BAND_CELLS as f64 + 2.0;
        let extent = (bounds.1 - bounds.0) / h + 2.0 * margin;
        let dims = IVec3::new(
            extent.x.ceil() as i32,
            extent.y.ceil() as i32,
            extent.z.ceil() as i32,
        )
        .max(IVec3::ONE);
        let longest = dims.max_element();
        let root_level = (longest as f64).log2().ceil().max(0.0) as u8;
        // The distance grid starts at the root's corner so octree cells align with its pyramid.
        let origin = bounds.0 - DVec3::splat(margin * h);
        let seeds: Vec<IVec3> = surface_samples
            .iter()
            .map(|&p| {
                let c = ((p - origin) / h).floor();
                IVec3::new(c.x as i32, c.y as i32, c.z as i32)
            })
            .collect();
        let grid = DistanceGrid::new(dims, &seeds, root_level);

        let inv_k = if params.grading > 0.0 {
            1.0 / params.grading
        } else {
            f64::INFINITY
        };
        let mut leaf_count = 0u64;
        refine(&grid, root_level, inv_k, |_| leaf_count += 1);
        let estimate = leaf_count.saturating_mul(2);
        if estimate > max_nodes {
            return Err(LimitExceeded {
                limit: Limit::LatticeNodes,
                count: estimate,
                max: max_nodes,
            });
        }
        let mut leaves: HashSet<Cell> = HashSet::new();
        refine(&grid, root_level, inv_k, |cell| {
            leaves.insert(cell);
        });
        balance(&mut leaves, root_level);
        let mut leaves_per_size = vec![0usize; root_level as usize + 1];
        for c in &leaves {
            leaves_per_size[c.level as usize] += 1;
        }
        let mut lattice = assemble(&leaves, root_level, origin, h);
        lattice.leaves_per_size = leaves_per_size;
        Ok(lattice)
    }

    /// The kind of lattice vertex `v` (corners have all-even half-cell coordinates).
    pub fn kind(&self, v: u32) -> LatticeVertexKind {
        self.kinds[v as usize]
    }
}

/// Top-down refinement of the octree by the distance rule: `leaf` is called once per leaf (before
/// balancing).
fn refine(grid: &DistanceGrid, root_level: u8, inv_k: f64, mut leaf: impl FnMut(Cell)) {
    let mut stack = vec![Cell {
        level: root_level,
        min: IVec3::ZERO,
    }];
    while let Some(cell) = stack.pop() {
        if cell.level == 0 {
            leaf(cell);
            continue;
        }
        let [all, interior, exterior] = grid.block_min(cell);
        let s = cell.size() as f64;
        let in_band = all <= FINE_BAND_CELLS;
        let interior_too_close = interior != u16::MAX && (interior as f64) < s * inv_k;
        // Outside, the lattice only has to stay balanced; K = 1 there.
        let exterior_too_close = (exterior as f64) < s;
        if in_band || interior_too_close || exterior_too_close {
            stack.extend(cell.children());
        } else {
            leaf(cell);
        }
    }
}

/// The leaf holding fine cell `p`, if `p` lies in the root.
fn leaf_at(leaves: &HashSet<Cell>, root_level: u8, p: IVec3) -> Option<Cell> {
    let root = 1 << root_level;
    if (p.cmplt(IVec3::ZERO) | p.cmpge(IVec3::splat(root))).any() {
        return None;
    }
    (0..=root_level).find_map(|level| {
        let s = 1 << level;
        let cell = Cell {
            level,
            min: p.div_euclid(IVec3::splat(s)) * s,
        };
        leaves.contains(&cell).then_some(cell)
    })
}

/// Splits leaves until leaves sharing a face, edge or corner differ at most 2x in size.
fn balance(leaves: &mut HashSet<Cell>, root_level: u8) {
    let mut work: Vec<Cell> = leaves.iter().copied().collect();
    while let Some(cell) = work.pop() {
        if !leaves.contains(&cell) {
            continue;
        }
        let s = cell.size();
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if (dx, dy, dz) == (0, 0, 0) {
                        continue;
                    }
                    // One fine cell just outside the face, edge or corner in direction d.
                    let probe = cell.min + IVec3::new(pick(dx, s), pick(dy, s), pick(dz, s));
                    if let Some(other) = leaf_at(leaves, root_level, probe) {
                        if other.level > cell.level + 1 {
                            leaves.remove(&other);
                            let kids = other.children();
                            leaves.extend(kids);
                            work.extend(kids);
                            work.push(cell);
                        }
                    }
                }
            }
        }
    }
}

fn pick(d: i32, s: i32) -> i32 {
    match d {
        -1 => -1,
        0 => 0,
        _ => s,
    }
}

/// Turns balanced leaves into lattice vertices and tetrahedra (see the module doc).
fn assemble(leaves: &HashSet<Cell>, root_level: u8, origin: DVec3, h: f64) -> BccLattice {
    let mut ids: HashMap<IVec3, u32> = HashMap::new();
    let mut coords: Vec<IVec3> = Vec::new();
    let mut kinds: Vec<LatticeVertexKind> = Vec::new();
    let mut corner_set: HashSet<IVec3> = HashSet::new();
    let mut vertex = |c: IVec3,
                      kind: LatticeVertexKind,
                      coords: &mut Vec<IVec3>,
                      kinds: &mut Vec<LatticeVertexKind>| {
        ids.entry(c).or_insert_with(|| {
            coords.push(c);
            kinds.push(kind);
            (coords.len() - 1) as u32
        });
    };
    // Sorted leaves make vertex numbering (and so the whole bake) deterministic.
    let mut sorted: Vec<Cell> = leaves.iter().copied().collect();
    sorted.sort_unstable_by_key(|c| (c.level, c.min.z, c.min.y, c.min.x));
    for cell in &sorted {
        let s2 = 2 * cell.size();
        let m2 = 2 * cell.min;
        for i in 0..8i32 {
            let o = IVec3::new(i & 1, (i >> 1) & 1, (i >> 2) & 1);
            vertex(
                m2 + o * s2,
                LatticeVertexKind::Corner,
                &mut coords,
                &mut kinds,
            );
            corner_set.insert(m2 + o * s2);
        }
        vertex(
            m2 + IVec3::splat(s2 / 2),
            LatticeVertexKind::Centre,
            &mut coords,
            &mut kinds,
        );
    }
    let lookup = |c: IVec3| -> u32 { ids_get(&ids, c) };
    let mut tets: Vec<[u32; 4]> = Vec::new();
    let mut finest: Vec<bool> = Vec::new();
    let axes = [IVec3::X, IVec3::Y, IVec3::Z];
    for cell in &sorted {
        let s = cell.size();
        let s2 = 2 * s;
        let centre = 2 * cell.min + IVec3::splat(s);
        for (axis, &dir) in axes.iter().enumerate() {
            for sign in [1, -1] {
                // A fine cell just across this face.
                let probe = if sign > 0 {
                    cell.min + dir * s
                } else {
                    cell.min - dir
                };
                let Some(other) = leaf_at(leaves, root_level, probe) else {
                    continue;
                };
                let face_centre = centre + dir * s * sign;
                let (u, v) = (axes[(axis + 1) % 3], axes[(axis + 2) % 3]);
                let corners = [
                    face_centre - u * s - v * s,
                    face_centre + u * s - v * s,
                    face_centre + u * s + v * s,
                    face_centre - u * s + v * s,
                ];
                let edges = [(0, 1), (1, 2), (2, 3), (3, 0)];
                if other.level == cell.level {
                    if sign < 0 {
                        continue; // emitted once, from the lower cell
                    }
                    let c2 = centre + dir * s2;
                    for (i, j) in edges {
                        let (a, b) = (corners[i], corners[j]);
                        let mid = (a + b) / 2;
                        if corner_set.contains(&mid) {
                            for (p, q) in [(a, mid), (mid, b)] {
                                tets.push([lookup(centre), lookup(c2), lookup(p), lookup(q)]);
                                finest.push(false);
                            }
                        } else {
                            tets.push([lookup(centre), lookup(c2), lookup(a), lookup(b)]);
                            finest.push(cell.level == 0);
                        }
                    }
                } else if other.level == cell.level + 1 {
                    let big_centre = 2 * other.min + IVec3::splat(other.size());
                    for (i, j) in edges {
                        tets.push([
                            lookup(centre),
                            lookup(big_centre),
                            lookup(corners[i]),
                            lookup(corners[j]),
                        ]);
                        finest.push(false);
                    }
                }
                // A smaller neighbour emits the tetrahedra of this face itself.
            }
        }
    }
    let vertices: Vec<DVec3> = coords
        .iter()
        .map(|c| origin + c.as_dvec3() * (h / 2.0))
        .collect();
    for t in &mut tets {
        let [a, b, c, d] = t.map(|i| vertices[i as usize]);
        if (b - a).dot((c - a).cross(d - a)) < 0.0 {
            t.swap(2, 3);
        }
    }
    BccLattice {
        vertices,
        coords,
        kinds,
        tets,
        finest,
        spacing: h,
        leaves_per_size: Vec::new(),
    }
}

fn ids_get(ids: &HashMap<IVec3, u32>, c: IVec3) -> u32 {
    // Every corner and centre of every leaf was inserted, and the tetrahedra only use those.
    ids.get(&c).copied().unwrap_or(u32::MAX)
}

/// How many points [`sample_surface`] returns for these triangles (saturating), counted without
/// allocating them: what the [`Limit::SurfaceSamples`] check needs.
pub fn surface_sample_count(positions: &[DVec3], triangles: &[[u32; 3]], max_gap: f64) -> u64 {
    triangles
        .iter()
        .map(|tri| {
            let Some([a, b, c]) = corners(positions, tri) else {
                return 0;
            };
            let n = per_edge(a, b, c, max_gap);
            // (n + 1)(n + 2) / 2 points of the triangular grid, in f64 to saturate, not wrap.
            ((n + 1.0) * (n + 2.0) / 2.0).min(u64::MAX as f64) as u64
        })
        .fold(0u64, u64::saturating_add)
}

fn corners(positions: &[DVec3], tri: &[u32; 3]) -> Option<[DVec3; 3]> {
    let [a, b, c] = tri.map(|i| positions.get(i as usize).copied());
    Some([a?, b?, c?])
}

/// Subdivisions of the longest edge so that samples are at most `max_gap` apart.
fn per_edge(a: DVec3, b: DVec3, c: DVec3, max_gap: f64) -> f64 {
    let longest = (b - a).length().max((c - b).length()).max((a - c).length());
    (longest / max_gap).ceil().max(1.0)
}

/// Points on the triangles of a surface, no farther apart than `max_gap` (for [`BccLattice::build`]).
pub fn sample_surface(positions: &[DVec3], triangles: &[[u32; 3]], max_gap: f64) -> Vec<DVec3> {
    let mut out = Vec::new();
    for tri in triangles {
        // A face with an index out of range is skipped, as `surface_sample_count` counts it.
        let Some([a, b, c]) = corners(positions, tri) else {
            continue;
        };
        let n = per_edge(a, b, c, max_gap) as usize;
        for i in 0..=n {
            for j in 0..=(n - i) {
                let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                out.push(a + (b - a) * u + (c - a) * v);
            }
        }
    }
    out
}
