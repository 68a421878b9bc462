//! Voxel grids of optical coefficients in Mitsuba 3's `.vol` format (DESIGN section 2).
//!
//! Layout, little-endian: bytes `VOL`, u8 version 3, i32 encoding 1 (dense f32), i32 xres, yres,
//! zres, i32 channels (6 here: sigma_s' R,G,B then sigma_a R,G,B in 1/mm), 6 f32 bounding box
//! (min xyz, max xyz, in mm in the normalized object frame), then f32 data indexed
//! `((z * yres + y) * xres + x) * channels + c`. Samples sit at cell centres, `(i + 0.5) / res`
//! across the box; sampling is trilinear and clamps to the border cells outside.
//!
//! ```
//! use glam::DVec3;
//! use translucent::material::VolGrid;
//! let grid = VolGrid::from_fn([4, 4, 4], DVec3::splat(-10.0), DVec3::splat(10.0), |p| {
//!     ([1.0, 1.0, 1.0], [0.01 * (p.x + 10.0), 0.0, 0.0])
//! })?;
//! let bytes = grid.to_bytes();
//! let back = VolGrid::from_bytes(&bytes)?;
//! assert_eq!(back, grid);
//! // Trilinear filtering reproduces a linear field exactly between cell centres.
//! assert!((back.sample(DVec3::new(1.0, 0.0, 0.0)).sigma_a[0] - 0.11).abs() < 1e-6);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::path::Path;

use glam::DVec3;

use super::{Coefficients, MaterialError};
use crate::limits::{Limit, LimitExceeded, Limits};

/// The channels every grid of ours has.
pub const VOL_CHANNELS: usize = 6;
const HEADER_BYTES: usize = 3 + 1 + 4 * 5 + 4 * 6;

/// What is wrong with a `.vol` file.
#[derive(Debug, thiserror::Error)]
pub enum VolError {
    #[error("cannot read or write: {0}")]
    Io(#[from] std::io::Error),
    #[error("not a .vol file (magic bytes {0:?}, expected \"VOL\")")]
    BadMagic([u8; 3]),
    #[error("unsupported version {0} (expected 3)")]
    BadVersion(u8),
    #[error("unsupported encoding {0} (expected 1, dense f32)")]
    BadEncoding(i32),
    #[error("bad resolution {0:?} (each must be >= 1, and the grid must fit in memory)")]
    BadResolution([i32; 3]),
    #[error("{0} channels (expected 6: sigma_s' RGB then sigma_a RGB)")]
    BadChannels(i32),
    #[error("bad bounding box min {min:?} max {max:?} (finite, min < max on every axis)")]
    BadBbox { min: [f32; 3], max: [f32; 3] },
    #[error("truncated: {actual} bytes, the header announces {expected}")]
    Truncated { expected: usize, actual: usize },
    #[error("{extra} bytes after the data the header announces")]
    TrailingBytes { extra: usize },
    #[error("voxel {voxel:?} channel {channel} is {value} (must be finite and >= 0)")]
    BadValue {
        voxel: [usize; 3],
        channel: usize,
        value: f32,
    },
    #[error("voxel {voxel:?} has sigma_t' = 0 in channel {channel}")]
    ZeroExtinction { voxel: [usize; 3], channel: usize },
    #[error(transparent)]
    Limit(#[from] LimitExceeded),
}

/// A dense 6-channel grid, validated: every value finite and >= 0, sigma_t' > 0 everywhere.
#[derive(Clone, Debug, PartialEq)]
pub struct VolGrid {
    /// Cells along x, y, z.
    pub res: [usize; 3],
    pub bbox_min: DVec3,
    pub bbox_max: DVec3,
    /// `((z * yres + y) * xres + x) * 6 + c`.
    pub data: Vec<f32>,
}

impl VolGrid {
    /// A grid filled by `f(cell centre) -> (sigma_s', sigma_a)`, validated.
    pub fn from_fn(
        res: [usize; 3],
        bbox_min: DVec3,
        bbox_max: DVec3,
        mut f: impl FnMut(DVec3) -> ([f64; 3], [f64; 3]),
    ) -> Result<Self, VolError> {
        let cells = cell_count(res).ok_or(VolError::BadResolution(res.map(|r| r as i32)))?;
        let mut data = Vec::with_capacity(cells * VOL_CHANNELS);
        let size = bbox_max - bbox_min;
        for z in 0..res[2] {
            for y in 0..res[1] {
                for x in 0..res[0] {
                    let u = DVec3::new(x as f64, y as f64, z as f64) + 0.5;
                    let p = bbox_min
                        + u / DVec3::new(res[0] as f64, res[1] as f64, res[2] as f64) * size;
                    let (s, a) = f(p);
                    data.extend(s.iter().chain(a.iter()).map(|&v| v as f32));
                }
            }
        }
        let grid = Self {
            res,
            bbox_min,
            bbox_max,
            data,
        };
        grid.validate()?;
        Ok(grid)
    }

    fn validate(&self) -> Result<(), VolError> {
        let (min, max) = (
            self.bbox_min.as_vec3().to_array(),
            self.bbox_max.as_vec3().to_array(),
        );
        let ok = (0..3).all(|i| min[i].is_finite() && max[i].is_finite() && min[i] < max[i]);
        if !ok {
            return Err(VolError::BadBbox { min, max });
        }
        let [xres, yres, _] = self.res;
        for (cell, v) in self.data.chunks_exact(VOL_CHANNELS).enumerate() {
            let voxel = [cell % xres, (cell / xres) % yres, cell / (xres * yres)];
            for (channel, &value) in v.iter().enumerate() {
                if !(value.is_finite() && value >= 0.0) {
                    return Err(VolError::BadValue {
                        voxel,
                        channel,
                        value,
                    });
                }
            }
            for channel in 0..3 {
                if v[channel] + v[channel + 3] <= 0.0 {
                    return Err(VolError::ZeroExtinction { voxel, channel });
                }
            }
        }
        Ok(())
    }

    /// Encodes the file contents.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(HEADER_BYTES + 4 * self.data.len());
        out.extend_from_slice(b"VOL");
        out.push(3);
        out.extend_from_slice(&1i32.to_le_bytes());
        for r in self.res {
            out.extend_from_slice(&(r as i32).to_le_bytes());
        }
        out.extend_from_slice(&(VOL_CHANNELS as i32).to_le_bytes());
        for v in self
            .bbox_min
            .as_vec3()
            .to_array()
            .iter()
            .chain(self.bbox_max.as_vec3().to_array().iter())
        {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in &self.data {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out
    }

    /// Decodes and validates file contents, within [`Limits::from_env`].
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, VolError> {
        Self::from_bytes_with_limits(bytes, &Limits::from_env())
    }

    /// Decodes and validates file contents; the resolution is checked against `limits`
    /// ([`Limit::VolAxis`], [`Limit::VolVoxels`]) before the data is looked at.
    pub fn from_bytes_with_limits(bytes: &[u8], limits: &Limits) -> Result<Self, VolError> {
        let header = Header::parse(bytes, limits)?;
        let expected = header.file_bytes();
        if bytes.len() < expected {
            return Err(VolError::Truncated {
                expected,
                actual: bytes.len(),
            });
        }
        if bytes.len() > expected {
            return Err(VolError::TrailingBytes {
                extra: bytes.len() - expected,
            });
        }
        let data = bytes[HEADER_BYTES..]
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        let bbox = header.bbox;
        let grid = Self {
            res: header.res,
            bbox_min: DVec3::new(bbox[0] as f64, bbox[1] as f64, bbox[2] as f64),
            bbox_max: DVec3::new(bbox[3] as f64, bbox[4] as f64, bbox[5] as f64),
            data,
        };
        grid.validate()?;
        Ok(grid)
    }

    /// Reads and validates a `.vol` file, within [`Limits::from_env`].
    pub fn read(path: &Path) -> Result<Self, MaterialError> {
        Self::read_with_limits(path, &Limits::from_env())
    }

    /// Reads and validates a `.vol` file. The header is read and checked against `limits` first;
    /// then no more than the bytes it announces (plus one, to tell trailing bytes) are read, so
    /// neither a huge resolution nor a huge file is allocated.
    pub fn read_with_limits(path: &Path, limits: &Limits) -> Result<Self, MaterialError> {
        use std::io::Read as _;
        let wrap = |problem| MaterialError::Vol {
            path: path.to_path_buf(),
            problem,
        };
        let mut file = std::fs::File::open(path).map_err(|e| wrap(VolError::Io(e)))?;
        let mut bytes = Vec::new();
        (&mut file)
            .take(HEADER_BYTES as u64)
            .read_to_end(&mut bytes)
            .map_err(|e| wrap(VolError::Io(e)))?;
        let expected = Header::parse(&bytes, limits).map_err(wrap)?.file_bytes();
        file.take((expected - HEADER_BYTES) as u64 + 1)
            .read_to_end(&mut bytes)
            .map_err(|e| wrap(VolError::Io(e)))?;
        Self::from_bytes_with_limits(&bytes, limits).map_err(wrap)
    }

    /// Writes atomically: a temporary file next to `path`, then a rename, so a failure never leaves
    /// a half-written grid behind.
    pub fn write(&self, path: &Path) -> Result<(), MaterialError> {
        let wrap = |e: std::io::Error| MaterialError::Vol {
            path: path.to_path_buf(),
            problem: VolError::Io(e),
        };
        let mut tmp_name = path
            .file_name()
            .map(|n| n.to_os_string())
            .unwrap_or_default();
        tmp_name.push(format!(".tmp{}", std::process::id()));
        let tmp = path.with_file_name(tmp_name);
        // Synced before the rename: a crash leaves the old grid or the new one under `path`.
        let result = std::fs::File::create(&tmp)
            .and_then(|mut f| {
                std::io::Write::write_all(&mut f, &self.to_bytes())?;
                f.sync_all()
            })
            .and_then(|()| std::fs::rename(&tmp, path));
        if result.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        result.map_err(wrap)
    }

    /// Trilinear sample at `p` (mm); cell centres at `(i + 0.5) / res` across the box, border cells
    /// repeat outside it.
    pub fn sample(&self, p: DVec3) -> Coefficients {
        let v = self.sample_raw(p);
        Coefficients {
            sigma_s: [v[0], v[1], v[2]],
            sigma_a: [v[3], v[4], v[5]],
        }
    }

    /// The 6 channels at `p`, trilinearly filtered.
    pub fn sample_raw(&self, p: DVec3) -> [f64; VOL_CHANNELS] {
        let [xr, yr, zr] = self.res;
        let u = (p - self.bbox_min) / (self.bbox_max - self.bbox_min)
            * DVec3::new(xr as f64, yr as f64, zr as f64)
            - 0.5;
        let axis = |u: f64, r: usize| {
            let u = u.clamp(0.0, (r - 1) as f64);
            let i0 = (u.floor() as usize).min(r - 1);
            let i1 = (i0 + 1).min(r - 1);
            (i0, i1, u - i0 as f64)
        };
        let (x0, x1, fx) = axis(u.x, xr);
        let (y0, y1, fy) = axis(u.y, yr);
        let (z0, z1, fz) = axis(u.z, zr);
        let at = |x: usize, y: usize, z: usize, c: usize| {
            self.data[((z * yr + y) * xr + x) * VOL_CHANNELS + c] as f64
        };
        std::array::from_fn(|c| {
            let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
            let c00 = lerp(at(x0, y0, z0, c), at(x1, y0, z0, c), fx);
            let c10 = lerp(at(x0, y1, z0, c), at(x1, y1, z0, c), fx);
            let c01 = lerp(at(x0, y0, z1, c), at(x1, y0, z1, c), fx);
            let c11 = lerp(at(x0, y1, z1, c), at(x1, y1, z1, c), fx);
            lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz)
        })
    }
}

/// The fixed-size start of a `.vol` file, checked.
struct Header {
    res: [usize; 3],
    bbox: [f32; 6],
}

impl Header {
    /// Parses and checks the header at the start of `bytes` (only its first [`HEADER_BYTES`]).
    fn parse(bytes: &[u8], limits: &Limits) -> Result<Header, VolError> {
        if bytes.len() < HEADER_BYTES {
            return Err(VolError::Truncated {
                expected: HEADER_BYTES,
                actual: bytes.len(),
            });
        }
        let magic = [bytes[0], bytes[1], bytes[2]];
        if &magic != b"VOL" {
            return Err(VolError::BadMagic(magic));
        }
        if bytes[3] != 3 {
            return Err(VolError::BadVersion(bytes[3]));
        }
        let word = |i: usize| {
            [
                bytes[4 + 4 * i],
                bytes[5 + 4 * i],
                bytes[6 + 4 * i],
                bytes[7 + 4 * i],
            ]
        };
        let encoding = i32::from_le_bytes(word(0));
        if encoding != 1 {
            return Err(VolError::BadEncoding(encoding));
        }
        let res_i = [1, 2, 3].map(|i| i32::from_le_bytes(word(i)));
        let channels = i32::from_le_bytes(word(4));
        if res_i.iter().any(|&r| r < 1) {
            return Err(VolError::BadResolution(res_i));
        }
        if channels != VOL_CHANNELS as i32 {
            return Err(VolError::BadChannels(channels));
        }
        for &r in &res_i {
            limits.check(Limit::VolAxis, r as u64)?;
        }
        let voxels = res_i.iter().fold(1u64, |n, &r| n.saturating_mul(r as u64));
        limits.check(Limit::VolVoxels, voxels)?;
        let res = res_i.map(|r| r as usize);
        // Both limits are u64: on a 32-bit target the byte count could still overflow usize.
        cell_count(res)
            .and_then(|c| c.checked_mul(VOL_CHANNELS * 4))
            .and_then(|b| b.checked_add(HEADER_BYTES))
            .ok_or(VolError::BadResolution(res_i))?;
        let bbox: [f32; 6] = std::array::from_fn(|i| f32::from_le_bytes(word(5 + i)));
        Ok(Header { res, bbox })
    }

    /// The size of the whole file the header announces (checked not to overflow in `parse`).
    fn file_bytes(&self) -> usize {
        HEADER_BYTES + self.res.iter().product::<usize>() * VOL_CHANNELS * 4
    }
}

fn cell_count(res: [usize; 3]) -> Option<usize> {
    if res.iter().any(|&r| r == 0 || r > i32::MAX as usize) {
        return None;
    }
    res[0].checked_mul(res[1])?.checked_mul(res[2])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// f32 data against f64 sampling.
    const SAMPLE_TOLERANCE: f64 = 1e-5;

    /// A grid with `value(x, y, z)` (cell indices) in channel 0 and 0.01 elsewhere.
    fn grid(res: [usize; 3], value: impl Fn(usize, usize, usize) -> f32) -> VolGrid {
        let mut data = Vec::new();
        for z in 0..res[2] {
            for y in 0..res[1] {
                for x in 0..res[0] {
                    data.push(value(x, y, z));
                    data.extend([0.01f32; VOL_CHANNELS - 1]);
                }
            }
        }
        let grid = VolGrid {
            res,
            bbox_min: DVec3::splat(-10.0),
            bbox_max: DVec3::splat(10.0),
            data,
        };
        grid.validate().expect("a valid grid");
        grid
    }

    /// Where Mitsuba 3.9.1's `gridvolume` (use_grid_bbox, trilinear; the reference tool's
    /// medium) puts the same files' values, measured with
    /// `target/pt-venv/bin/python benches/heterogeneous/mitsuba_grid_convention.py`: samples at
    /// cell centres, x fastest, clamped to the border cells, +y up as in our object frame. A
    /// corner convention, another axis order or a flipped axis each fail here.
    #[test]
    fn sampling_puts_an_asymmetric_grid_where_mitsuba_puts_it() {
        // Two cells along y (0 below, 1 above, plus 1): a ramp between the centres y = -5, 5.
        let two = grid([1, 2, 1], |_, y, _| 1.0 + y as f32);
        for (y, mitsuba) in [
            (-10.0, 0.0),
            (-7.5, 0.0),
            (-5.0, 0.0),
            (-2.5, 0.25),
            (0.0, 0.5),
            (2.5, 0.75),
            (5.0, 1.0),
            (7.5, 1.0),
            (10.0, 1.0),
        ] {
            let ours = two.sample(DVec3::new(3.0, y, -2.0)).sigma_s[0];
            assert!(
                (ours - (1.0 + mitsuba)).abs() < SAMPLE_TOLERANCE,
                "y {y}: {ours}"
            );
        }
        // 2 x 1 x 3 cells holding x + 10 z (plus 1).
        let asymmetric = grid([2, 1, 3], |x, _, z| 1.0 + x as f32 + 10.0 * z as f32);
        let third = 20.0 / 3.0;
        for (p, mitsuba) in [
            ([-5.0, 0.0, -third], 0.0),
            ([5.0, 0.0, -third], 1.0),
            ([-5.0, 0.0, 0.0], 10.0),
            ([-5.0, 0.0, third], 20.0),
            ([0.0, 0.0, 0.0], 10.5),
        ] {
            let ours = asymmetric.sample(DVec3::from_array(p)).sigma_s[0];
            assert!(
                (ours - (1.0 + mitsuba)).abs() < SAMPLE_TOLERANCE,
                "{p:?}: {ours}"
            );
        }
    }
}
