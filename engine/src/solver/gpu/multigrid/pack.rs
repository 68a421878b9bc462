//! The operators' upload layout: compressed rows over all levels, the coarse levels' entries in
//! fp16 relative to their row's scale with the rounding lumped onto the f32 diagonal.

use super::*;

/// The operators of every level as the kernels read them (compressed rows, every level's entries
/// after the previous level's, coarsest first; columns and partners as global node indices).
pub(super) struct PackedOperators {
    pub(super) row_start: Vec<u32>,
    pub(super) cols: Vec<u32>,
    /// RGB f32 entries, three floats each (no fourth lane): all of them, or with fp16 coarse
    /// levels the finest level's only (entry `e` at floats `3 (e - half_entries)..`).
    pub(super) values: Vec<f32>,
    /// RGB fp16 entries (r|g, b|0) of the coarse levels relative to their row's scale `diag.a`.
    pub(super) values16: Vec<[u32; 2]>,
    /// Entries stored in `values16`: those of every level below the finest (0 with f32 storage).
    pub(super) half_entries: u32,
    /// Every `values16` entry holds its column, the node's index in its level, in its top 16
    /// bits (`HALF_COLUMN` in `common.glsl`): every fp16 level has at most 65536 nodes. `cols`
    /// holds the columns too (the f32 entries' readers index it by entry).
    pub(super) packed_columns: bool,
    /// RGB diagonal (with fp16 entries: plus the row's rounding, so the row sums as before) and
    /// the row's scale of its fp16 entries in the fourth lane (0 where unused).
    pub(super) diag: Vec<[f32; 4]>,
    pub(super) partner: Vec<u32>,
    /// RGB, the vectors' stride of floats per node.
    pub(super) partner_value: Vec<f32>,
}

impl PackedOperators {
    /// What the `cols` buffer holds: nothing where no kernel reads it (`unread`: the fp16 rows
    /// read their columns from their entries and the finest level stores no rows), else `cols`.
    pub(super) fn stored_cols(&self, unread: bool) -> &[u32] {
        if unread {
            &[]
        } else {
            &self.cols
        }
    }
}

/// Whether the kernels read the fp16 entries' columns from `values16` where
/// [`PackedOperators::packed_columns`] allows it: the environment variable
/// `TRANSLUCENT_MULTIGRID_COLUMNS`, read when the solver is created: `cols` (from `cols`, as
/// before wave 11), unset or `packed` (from the entries).
pub(super) fn packed_columns_from_env() -> bool {
    std::env::var("TRANSLUCENT_MULTIGRID_COLUMNS").as_deref() != Ok("cols")
}

/// The row of `values16` and its effective f32 values (what `residual.comp` multiplies with):
/// `v / scale` rounded to fp16, times `scale` again.
pub(super) fn half_entry(v: [f64; 3], scale: f64) -> ([u32; 2], [f64; 3]) {
    let h = v.map(|c| half::f16::from_f64(c / scale));
    let bits = |a: half::f16, b: half::f16| u32::from(a.to_bits()) | (u32::from(b.to_bits()) << 16);
    let scale32 = scale as f32;
    let effective = h.map(|c| f64::from(c.to_f32() * scale32));
    ([bits(h[0], h[1]), bits(h[2], half::f16::ZERO)], effective)
}

/// Packs `hierarchy`'s operators for the kernels (`residual.comp`, `krylov.comp`), the coarse
/// levels' entries in fp16 under [`OperatorStorage::F16`]: each row's entries divided by the
/// row's largest diagonal channel (an fp32 value, so a 1e4 contrast or a 10 m object stays inside
/// fp16's range: |entry| <= diagonal for these M-matrices), and the rounding `v - fp16(v)` of the
/// row added to its diagonal, so that `K 1` (the absorption) is unchanged row by row.
pub(super) fn pack_operators(
    hierarchy: &Hierarchy,
    offsets: &[usize],
    params: &MultigridParams,
) -> Result<PackedOperators, Error> {
    let storage = params.coarse_storage;
    let stride = params.vector_storage.floats();
    let total = offsets.last().copied().unwrap_or(0);
    let top = hierarchy.levels.len().saturating_sub(1);
    let packed_columns = storage == OperatorStorage::F16
        && hierarchy.levels[..top]
            .iter()
            .all(|level| level.operator.node_count() <= 1 << 16);
    let mut out = PackedOperators {
        row_start: Vec::with_capacity(total + 1),
        cols: Vec::new(),
        values: Vec::new(),
        values16: Vec::new(),
        half_entries: 0,
        packed_columns,
        diag: Vec::with_capacity(total),
        partner: Vec::with_capacity(total),
        partner_value: Vec::with_capacity(stride * total),
    };
    // The matrix-free finest level (`FinestOperator::Graph`) keeps its diagonal and partners, not
    // its rows: `row_start` then ends with the coarse levels' rows.
    let graph_finest = params.finest_operator == FinestOperator::Graph;
    for (l, level) in hierarchy.levels.iter().enumerate() {
        let k = &level.operator;
        let rows = !(graph_finest && l == top);
        let half = storage == OperatorStorage::F16 && l < top;
        let base = out.cols.len();
        let off = offsets[l] as u32;
        for i in 0..k.node_count() {
            let mut d = rgb(k.diag[i]);
            if rows {
                let start = base + k.row_start[i];
                out.row_start
                    .push(u32::try_from(start).map_err(|_| too_big("the operator"))?);
                let row = k.row_start[i]..k.row_start[i + 1];
                if half {
                    let scale = f64::from(d[0].max(d[1]).max(d[2]));
                    let mut diag = k.diag[i];
                    for e in row {
                        let (mut bits, effective) = half_entry(k.values[e], scale);
                        if packed_columns {
                            bits[1] |= k.cols[e] << 16;
                        }
                        out.values16.push(bits);
                        for c in 0..3 {
                            diag[c] += k.values[e][c] - effective[c];
                        }
                    }
                    d = rgb(diag);
                    d[3] = scale as f32;
                } else {
                    out.values
                        .extend(row.flat_map(|e| k.values[e].map(|v| v as f32)));
                }
            }
            out.diag.push(d);
            let p = k.partner.get(i).copied().unwrap_or(NO_NODE);
            out.partner
                .push(if p == NO_NODE { NO_NODE } else { p + off });
            let pv = k.partner_value.get(i).copied().map_or([0.0; 4], rgb);
            out.partner_value.extend_from_slice(&pv[..stride]);
        }
        if rows {
            out.cols.extend(k.cols.iter().map(|&c| c + off));
        }
        if half {
            out.half_entries =
                u32::try_from(out.cols.len()).map_err(|_| too_big("the operator"))?;
        }
    }
    out.row_start
        .push(u32::try_from(out.cols.len()).map_err(|_| too_big("the operator"))?);
    Ok(out)
}
