//! [`PingPong`]: the parity rule of the Jacobi ping-pong, in one place. A level has two state
//! images; a sweep reads one and writes the other. Blocks hold an even number `k` of
//! iterations, so a level's latest iterate after whole blocks is always in the same image:
//! - `Fp32`/`Fp16`: k sweeps, sweep j reads `state[j % 2]`: the latest iterate is `state[0]`,
//!   the one before it `state[1]`;
//! - `Mixed`: the residual pass writes the correction delta into `state[0]`, then k - 1 (odd)
//!   correction sweeps leave the last delta in `state[1]` (the one before in `state[0]`), which
//!   `apply` adds to phi (RGBA32F).

use super::Precision;

/// Which state image each step of a block reads and writes (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PingPong {
    precision: Precision,
}

impl PingPong {
    pub fn new(precision: Precision) -> PingPong {
        PingPong { precision }
    }

    /// The state index a block starts from: what the initialisation writes (Fp32/Fp16) and the
    /// residual pass writes its delta into (Mixed).
    pub const FIRST: usize = 0;

    /// (source, destination) state indices of the two iteration descriptor sets, in set order.
    pub const SETS: [(usize, usize); 2] = [(0, 1), (1, 0)];

    /// The iteration descriptor set of sweep `j` of a block (0-based; in `Mixed`, counting the
    /// correction sweeps after the residual pass).
    pub fn sweep_set(self, j: u32) -> usize {
        (j % 2) as usize
    }

    /// (latest, previous) state indices after whole blocks: what the convergence reduction
    /// compares, and in `Mixed` the correction `apply` adds.
    pub fn latest(self) -> (usize, usize) {
        match self.precision {
            Precision::Mixed => (1, 0),
            Precision::Fp32 | Precision::Fp16 => (0, 1),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Walks a block through the sets and checks that the latest iterate lands where `latest`
    /// says, for every precision.
    #[test]
    fn a_block_ends_in_the_image_latest_names() {
        for (precision, sweeps, start) in [
            (Precision::Fp32, 8, 0),
            (Precision::Fp16, 8, 0),
            // Mixed: the residual pass wrote delta into state[0]; k - 1 sweeps follow.
            (Precision::Mixed, 7, 0),
        ] {
            let pp = PingPong::new(precision);
            let mut written = start;
            let mut before = usize::MAX;
            for j in 0..sweeps {
                let (src, dst) = PingPong::SETS[pp.sweep_set(j)];
                assert_eq!(
                    src, written,
                    "{precision:?}: sweep {j} reads the last iterate"
                );
                before = written;
                written = dst;
            }
            assert_eq!((written, before), pp.latest(), "{precision:?}");
        }
    }
}
