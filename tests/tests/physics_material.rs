//! Materials as a host sees them: presets, typed errors, `.vol` round trips through files, every
//! kind of corrupt `.vol` file rejected with its own error, atomic writes.

use std::path::PathBuf;

use glam::DVec3;
use translucent::material::{Material, MaterialError, MaterialField, VolError, VolGrid};

fn temp_dir(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("translucent-physics-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn sample_grid() -> VolGrid {
    VolGrid::from_fn(
        [5, 3, 4],
        DVec3::new(-10.0, -5.0, -8.0),
        DVec3::new(10.0, 5.0, 8.0),
        |p| {
            (
                [1.0 + 0.05 * p.x, 2.0, 3.0 + 0.1 * p.z],
                [0.01, 0.02 + 0.001 * p.y, 0.03],
            )
        },
    )
    .unwrap()
}

#[test]
fn every_preset_loads_and_derives_finite_coefficients() {
    for p in translucent::material::presets::PRESETS {
        let m = Material::preset(p.name).unwrap();
        assert!(
            m.kappa()
                .iter()
                .chain(m.mu().iter())
                .all(|v| v.is_finite() && *v >= 0.0),
            "{}",
            p.name
        );
        assert!(m.a() > 1.0 && m.f_dr() > 0.0 && m.f_dr() < 1.0);
    }
    assert!(matches!(
        Material::preset("jade"),
        Err(MaterialError::UnknownPreset { .. })
    ));
}

#[test]
fn vol_round_trips_through_a_file_and_samples_trilinearly() {
    let dir = temp_dir("roundtrip");
    let path = dir.join("grid.vol");
    let grid = sample_grid();
    grid.write(&path).unwrap();
    let back = VolGrid::read(&path).unwrap();
    assert_eq!(back, grid);
    // No temporary file left next to the grid.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    // Linear fields are reproduced exactly between cell centres, clamped outside.
    let field = MaterialField::grid(back, 1.3).unwrap();
    let c = field.sample(DVec3::new(3.0, 0.0, 2.0));
    assert!(
        (c.sigma_s[0] - 1.15).abs() < 1e-6 && (c.sigma_s[2] - 3.2).abs() < 1e-6,
        "{c:?}"
    );
    let corner = field.sample(DVec3::splat(1e6));
    let centre_x = 10.0 - 2.0; // last cell centre along x
    assert!(
        (corner.sigma_s[0] - (1.0 + 0.05 * centre_x)).abs() < 1e-6,
        "{corner:?}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

fn expect(bytes: &[u8], check: impl Fn(&VolError) -> bool, what: &str) {
    match VolGrid::from_bytes(bytes) {
        Err(e) if check(&e) => {}
        other => panic!("{what}: got {other:?}"),
    }
}

#[test]
fn corrupt_vol_files_are_typed_errors() {
    let good = sample_grid().to_bytes();
    let set_i32 = |offset: usize, v: i32| {
        let mut b = good.clone();
        b[offset..offset + 4].copy_from_slice(&v.to_le_bytes());
        b
    };
    let set_f32 = |index: usize, v: f32| {
        let mut b = good.clone();
        let at = 48 + 4 * index;
        b[at..at + 4].copy_from_slice(&v.to_le_bytes());
        b
    };
    let mut magic = good.clone();
    magic[0] = b'X';
    expect(&magic, |e| matches!(e, VolError::BadMagic(_)), "magic");
    let mut version = good.clone();
    version[3] = 2;
    expect(
        &version,
        |e| matches!(e, VolError::BadVersion(2)),
        "version",
    );
    expect(
        &set_i32(4, 2),
        |e| matches!(e, VolError::BadEncoding(2)),
        "encoding",
    );
    expect(
        &set_i32(8, 0),
        |e| matches!(e, VolError::BadResolution(_)),
        "zero resolution",
    );
    expect(
        &set_i32(8, -3),
        |e| matches!(e, VolError::BadResolution(_)),
        "negative resolution",
    );
    expect(
        &set_i32(8, i32::MAX),
        // The axis limit (issue 17) refuses it from the header, before any allocation.
        |e| {
            matches!(
                e,
                VolError::Truncated { .. } | VolError::BadResolution(_) | VolError::Limit(_)
            )
        },
        "huge resolution",
    );
    expect(
        &set_i32(20, 3),
        |e| matches!(e, VolError::BadChannels(3)),
        "channels",
    );
    expect(
        &good[..good.len() - 1],
        |e| matches!(e, VolError::Truncated { .. }),
        "truncated data",
    );
    expect(
        &good[..20],
        |e| matches!(e, VolError::Truncated { .. }),
        "truncated header",
    );
    let mut trailing = good.clone();
    trailing.push(0);
    expect(
        &trailing,
        |e| matches!(e, VolError::TrailingBytes { extra: 1 }),
        "trailing",
    );
    // Bounding box: min x > max x, and a NaN.
    let mut bbox = good.clone();
    bbox[24..28].copy_from_slice(&20.0f32.to_le_bytes());
    expect(
        &bbox,
        |e| matches!(e, VolError::BadBbox { .. }),
        "inverted bbox",
    );
    let mut bbox = good.clone();
    bbox[40..44].copy_from_slice(&f32::NAN.to_le_bytes());
    expect(&bbox, |e| matches!(e, VolError::BadBbox { .. }), "NaN bbox");
    expect(
        &set_f32(7, f32::NAN),
        |e| matches!(e, VolError::BadValue { channel: 1, .. }),
        "NaN value",
    );
    expect(
        &set_f32(9, f32::INFINITY),
        |e| matches!(e, VolError::BadValue { channel: 3, .. }),
        "Inf value",
    );
    expect(
        &set_f32(6 * 5 + 4, -0.5),
        |e| {
            matches!(
                e,
                VolError::BadValue {
                    voxel: [0, 1, 0],
                    channel: 4,
                    ..
                }
            )
        },
        "negative value",
    );
    let mut zero = good.clone();
    for c in [0usize, 3] {
        zero[48 + 4 * c..52 + 4 * c].copy_from_slice(&0.0f32.to_le_bytes());
    }
    expect(
        &zero,
        |e| matches!(e, VolError::ZeroExtinction { channel: 0, .. }),
        "zero extinction",
    );
    expect(&[], |e| matches!(e, VolError::Truncated { .. }), "empty");

    // Through the file API the error names the file.
    let dir = temp_dir("corrupt");
    let path = dir.join("bad.vol");
    std::fs::write(&path, &magic).unwrap();
    let e = VolGrid::read(&path).unwrap_err();
    assert!(e.to_string().contains("bad.vol"), "{e}");
    let missing = VolGrid::read(&dir.join("missing.vol")).unwrap_err();
    assert!(matches!(
        missing,
        MaterialError::Vol {
            problem: VolError::Io(_),
            ..
        }
    ));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn failed_writes_leave_nothing_behind() {
    let dir = temp_dir("atomic");
    let target = dir.join("no-such-dir").join("grid.vol");
    assert!(matches!(
        sample_grid().write(&target),
        Err(MaterialError::Vol { .. })
    ));
    assert!(!target.exists());
    // Writing over a directory fails at the rename; the temporary file is removed.
    let blocker = dir.join("taken.vol");
    std::fs::create_dir(&blocker).unwrap();
    std::fs::write(blocker.join("keep"), b"x").unwrap();
    assert!(sample_grid().write(&blocker).is_err());
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        1,
        "a temporary file was left behind"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
