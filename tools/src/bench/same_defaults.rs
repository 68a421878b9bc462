//! `render`, `view`, `bench` and the library resolve the same settings for the same inputs
//! (issue 13: one place for defaults, `translucent::defaults`). Where a command deliberately
//! differs the test names the difference: bench pins the boundary-flux source, no single
//! scattering, no bounce and the material's own (classical) diffusion coefficient (its errors
//! compare with the boundary-flux system's exact solution), and the
//! viewer's single-scattering and precision switches are its state.

use clap::Parser as _;
use translucent::defaults::{Schedule, Settings};
use translucent::frame::BounceMode;
use translucent::material::DiffusionCoefficient;
use translucent::solver::transport::Source;
use translucent::ObjectParams;

use super::sweep::Sweep;
use crate::{Cli, Command};

fn parse(argv: &[&str]) -> Command {
    let mut full = vec!["translucent"];
    full.extend_from_slice(argv);
    Cli::try_parse_from(&full)
        .unwrap_or_else(|e| panic!("{full:?}: {e}"))
        .command
}

/// What `translucent render OPTIONS --out x.png` runs.
fn render(options: &[&str]) -> Settings {
    let mut argv = vec!["render", "--out", "x.png"];
    argv.extend_from_slice(options);
    let Command::Render(args) = parse(&argv) else {
        unreachable!("render")
    };
    args.settings().expect("render's settings")
}

/// What `translucent view OPTIONS` starts with (its first frame's object).
#[cfg(feature = "window")]
fn view(options: &[&str]) -> Settings {
    let mut argv = vec!["view"];
    argv.extend_from_slice(options);
    let Command::View(args) = parse(&argv) else {
        unreachable!("view")
    };
    let homogeneous = !args.material.is_heterogeneous();
    crate::view::view_settings(
        &args,
        args.method.parse().expect("method"),
        homogeneous,
        args.precision.parse().expect("precision"),
        crate::view::start_single_scattering(&args),
    )
}

/// What `translucent bench OPTIONS --out d` runs in its first configuration.
fn bench(options: &[&str]) -> Settings {
    let mut argv = vec!["bench", "--out", "d"];
    argv.extend_from_slice(options);
    let Command::Bench(args) = parse(&argv) else {
        unreachable!("bench")
    };
    let sweep = Sweep::parse(&args).expect("sweep");
    let config = &sweep.configs()[0];
    let field = args
        .material
        .field(args.size_mm, crate::render::DEFAULT_MATERIAL)
        .expect("material");
    super::gpu::sweep_settings(config, &field)
}

/// What the library's `ObjectParams::for_material` gives for the same material.
fn library(material: &[&str]) -> Settings {
    let mut argv = vec!["render", "--out", "x.png"];
    argv.extend_from_slice(material);
    let Command::Render(args) = parse(&argv) else {
        unreachable!("render")
    };
    let field = args
        .material
        .field(args.object.size_mm, crate::render::DEFAULT_MATERIAL)
        .expect("material");
    Settings::of(&ObjectParams::for_material(&field))
}

/// The materials the defaults depend on: homogeneous (the default skim milk, a preset) and
/// heterogeneous (a procedural field).
const MATERIALS: [&[&str]; 3] = [&[], &["--material", "marble"], &["--material", "agate"]];

#[test]
fn render_view_and_the_library_resolve_the_same_defaults() {
    for material in MATERIALS {
        let r = render(material);
        assert_eq!(r, library(material), "{material:?}");
        #[cfg(feature = "window")]
        assert_eq!(r, view(material), "{material:?}");
        assert_eq!(r.schedule, Schedule::Multigrid, "{material:?}");
        assert!(r.single_scattering.is_some(), "{material:?}");
    }
    assert_eq!(render(&[]).source, Source::SecondCollision);
    // Grosjean's D: render's QuadGraph default is the library's (and so the viewer's); the
    // other methods keep the classical one.
    assert_eq!(render(&[]).diffusion, DiffusionCoefficient::Grosjean);
    assert_eq!(
        render(&["--method", "voxel"]).diffusion,
        DiffusionCoefficient::Classical
    );
    // One bounce: the QuadGraph's default; the other methods and the CPU solver have none
    // unless named.
    assert_eq!(render(&[]).bounce, BounceMode::Local);
    assert_eq!(render(&["--bounce", "off"]).bounce, BounceMode::Off);
    for options in [
        &["--method", "voxel"][..],
        &["--method", "dipole"],
        &["--solver", "cpu"],
    ] {
        assert_eq!(render(options).bounce, BounceMode::Off, "{options:?}");
    }
    // Heterogeneous materials take the second-collision source too (wave 9, benches/RESULTS.md
    // "The split .vol sphere, decomposed").
    assert_eq!(
        render(&["--material", "agate"]).source,
        Source::SecondCollision
    );
}

#[test]
fn named_options_resolve_alike_in_render_and_view() {
    #[cfg(feature = "window")]
    for options in [
        &["--precision", "fp16"][..],
        &["--scheme", "paper"],
        &["--iterations", "300"],
        &["--schedule", "cascade", "--tolerance", "1e-3"],
        &["--precision", "fp32", "--single-scattering", "off"],
    ] {
        assert_eq!(render(options), view(options), "{options:?}");
    }
    assert_eq!(render(&["--precision", "fp16"]).schedule, Schedule::Cascade);
    assert_eq!(render(&["--scheme", "paper"]).schedule, Schedule::Cascade);
}

#[test]
fn bench_differs_from_render_only_by_its_documented_pins() {
    for material in MATERIALS {
        let mut options = material.to_vec();
        options.extend(["--tolerance", "1e-4"]);
        let b = bench(&options);
        // The pins (BenchArgs' page): the boundary flux, no single scattering.
        assert_eq!(b.source, Source::BoundaryFlux);
        assert_eq!(b.single_scattering, None);
        assert_eq!(b.bounce, BounceMode::Off);
        assert_eq!(b.diffusion, DiffusionCoefficient::Classical);
        options.extend([
            "--diffusion-coefficient",
            "classical",
            "--source",
            "flux",
            "--single-scattering",
            "off",
            "--bounce",
            "off",
        ]);
        assert_eq!(b, render(&options), "{material:?}");
    }
}

/// The exit lobe (not a [`Settings`] field: a shading choice, per frame): render's, bench's first
/// configuration's and the library's real-time defaults' ([`ObjectParams::for_material`]) are
/// [`translucent::defaults::EXIT_LOBE`].
#[test]
fn render_bench_and_the_library_share_the_exit_lobe() {
    use translucent::defaults::EXIT_LOBE;
    let Command::Render(args) = parse(&["render", "--out", "x.png"]) else {
        unreachable!("render")
    };
    assert_eq!(args.scene.exit_lobes().expect("lobe"), vec![EXIT_LOBE]);
    let Command::Bench(args) = parse(&["bench", "--out", "d"]) else {
        unreachable!("bench")
    };
    let sweep = Sweep::parse(&args).expect("sweep");
    assert_eq!(sweep.configs()[0].exit_lobe, EXIT_LOBE);
    for material in MATERIALS {
        let Command::Render(args) = parse(&[&["render", "--out", "x.png"][..], material].concat())
        else {
            unreachable!("render")
        };
        let field = args
            .material
            .field(args.object.size_mm, crate::render::DEFAULT_MATERIAL)
            .expect("material");
        assert_eq!(ObjectParams::for_material(&field).exit_lobe, EXIT_LOBE);
    }
}

#[test]
fn the_bench_defaults_are_the_library_defaults() {
    let library = Settings::default();
    assert_eq!(super::DEFAULT_SCHEDULE, library.schedule.name());
    let b = bench(&[]);
    assert_eq!(b.schedule, library.schedule);
    assert_eq!(b.cascade_iterations, library.cascade_iterations);
    assert_eq!(b.precision, library.precision);
    assert_eq!(b.scheme, library.scheme);
}
