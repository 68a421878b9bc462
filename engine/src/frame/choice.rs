//! `--method auto`: which method to run for a scene, and why (DESIGN section 6), from what the
//! scene is made of, not from a measurement at run time. The rule is backed by the methods' time
//! against error on the path-traced references (`translucent bench --method
//! quadgraph,voxel,dipole`, benches/RESULTS.md "Choosing a method"):
//!
//! 1. the mesh changes topology (a fracture, a re-mesh: [`crate::TranslucentObject::set_mesh`])
//!    -> **voxel**: the only method with no per-mesh precomputation (the QuadGraph bakes a
//!    tetrahedral graph, the dipole a face-cluster hierarchy and its links);
//! 2. a heterogeneous material -> **quadgraph**: the dipole refuses it (or keeps only a texture);
//!    since the second-collision source reached heterogeneous materials (wave 9) the QuadGraph's
//!    image error on the split .vol sphere is 7.8% against the voxel method's 11.2%;
//! 3. an environment light -> **quadgraph**: the dipole and the voxel method see the environment
//!    as a flat irradiance (semi-infinite slab, one injected q); the QuadGraph's diffusion closes
//!    the solid and is near the path tracer;
//! 4. the object deforms (no topology change) -> **quadgraph**: it deforms its baked graph on the
//!    GPU; the dipole relinks on the CPU after each deformation (seconds on large meshes, or
//!    spread over frames in its incremental mode);
//! 5. otherwise (homogeneous, delta lights only, rigid) -> **quadgraph**: at the real-time
//!    defaults it has the lowest image error of the three methods on every path-traced
//!    reference (benches/RESULTS.md "The methods at their defaults, wave 10": e.g. marble sphere
//!    4.8% against the dipole's 5.2% and the voxel method's 6.5%, back-lit marble 6.6% against
//!    34.1% and 36.6%). The dipole (cheapest frame once linked, minutes of CPU linking at
//!    creation) stays a method to name.
//!
//! ```
//! use translucent::frame::{choose_method, MethodKind, SceneTraits};
//! let choice = choose_method(&SceneTraits { topology_changes: true, ..SceneTraits::default() });
//! assert_eq!(choice.kind, MethodKind::Voxel);
//! println!("{}: {}", choice.kind.name(), choice.reason);
//! ```

use super::method::MethodKind;
use crate::material::MaterialField;
use crate::scene::{Environment, Scene};

/// What [`choose_method`] looks at.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneTraits {
    /// The material varies in space (a volume or a procedural field).
    pub heterogeneous: bool,
    /// Some light comes from an environment (constant or SH).
    pub environment: bool,
    /// The host changes the mesh's topology between frames (`set_mesh`).
    pub topology_changes: bool,
    /// The host deforms the object between frames (`deform`).
    pub deforms: bool,
}

impl SceneTraits {
    /// The traits of a material and scene for a rigid object (the host adds
    /// `topology_changes` / `deforms`).
    pub fn of(field: &MaterialField, scene: &Scene) -> SceneTraits {
        SceneTraits {
            heterogeneous: !field.is_homogeneous(),
            environment: !matches!(scene.environment, Environment::None),
            ..SceneTraits::default()
        }
    }
}

/// The method [`choose_method`] picked and the rule that picked it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MethodChoice {
    pub kind: MethodKind,
    /// One sentence: which rule of the module's list applied.
    pub reason: &'static str,
}

/// The rule of the module documentation, first match wins.
pub fn choose_method(traits: &SceneTraits) -> MethodChoice {
    let (kind, reason) = if traits.topology_changes {
        (
            MethodKind::Voxel,
            "the topology changes: the voxel method needs no per-mesh precomputation",
        )
    } else if traits.heterogeneous {
        (
            MethodKind::QuadGraph,
            "heterogeneous material: the dipole refuses it; quadgraph has the lower error on the heterogeneous reference",
        )
    } else if traits.environment {
        (
            MethodKind::QuadGraph,
            "environment light: the quadgraph diffusion is closest to path tracing under an environment",
        )
    } else if traits.deforms {
        (
            MethodKind::QuadGraph,
            "the object deforms: the quadgraph deforms its baked graph on the GPU; the dipole relinks on the CPU per deformation",
        )
    } else {
        (
            MethodKind::QuadGraph,
            "homogeneous, rigid, delta lights only: quadgraph has the lowest error of the three methods on every path-traced reference",
        )
    };
    MethodChoice { kind, reason }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_rule_picks_its_method_and_the_first_match_wins() {
        let pick = |t: SceneTraits| choose_method(&t).kind;
        let rigid = SceneTraits::default();
        assert_eq!(pick(rigid), MethodKind::QuadGraph);
        let env = SceneTraits {
            environment: true,
            ..rigid
        };
        assert_eq!(pick(env), MethodKind::QuadGraph);
        let het = SceneTraits {
            heterogeneous: true,
            ..rigid
        };
        assert_eq!(pick(het), MethodKind::QuadGraph);
        // A heterogeneous material under an environment: rule 2 comes before rule 3.
        let het_env = SceneTraits {
            environment: true,
            ..het
        };
        assert_eq!(choose_method(&het_env).reason, choose_method(&het).reason);
        assert_ne!(choose_method(&het_env).reason, choose_method(&env).reason);
        let deforms = SceneTraits {
            deforms: true,
            ..rigid
        };
        assert_eq!(pick(deforms), MethodKind::QuadGraph);
        // A topology change overrides everything, including an environment.
        let split = SceneTraits {
            topology_changes: true,
            environment: true,
            deforms: true,
            ..rigid
        };
        assert_eq!(pick(split), MethodKind::Voxel);
        // Every rule gives its own reason.
        let reasons: std::collections::BTreeSet<&str> = [rigid, env, het, deforms, split]
            .iter()
            .map(|t| choose_method(t).reason)
            .collect();
        assert_eq!(reasons.len(), 5);
    }

    #[test]
    fn traits_come_from_the_material_and_the_scene() {
        let marble = crate::material::Material::preset("marble").expect("preset");
        let field = MaterialField::Homogeneous(marble);
        let lit = Scene {
            lights: vec!["dir:0,-1,0:1,1,1".parse().expect("light")],
            environment: Environment::None,
        };
        assert_eq!(SceneTraits::of(&field, &lit), SceneTraits::default());
        let env = Scene {
            environment: Environment::Constant([1.0; 3]),
            ..lit
        };
        assert!(SceneTraits::of(&field, &env).environment);
    }
}
