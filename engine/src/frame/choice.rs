//! `--method auto`: which method to run for a scene, and why (DESIGN section 6), from what the
//! scene is made of, not from a measurement at run time. The rule is backed by the methods' time
//! against error on the path-traced references (`translucent bench --method
//! quadgraph,voxel,dipole`, benches/RESULTS.md "Choosing a method"):
//!
//! 1. the mesh changes topology (a fracture, a re-mesh: [`crate::TranslucentObject::set_mesh`])
//!    -> **voxel**: the only method with no per-mesh precomputation (the QuadGraph bakes a
//!    tetrahedral graph, the dipole a face-cluster hierarchy and its links);
//! 2. a heterogeneous material -> **voxel**: the dipole refuses it (or keeps only a texture), and
//!    on the heterogeneous reference (skim milk / skin1 split sphere) the voxel method's image
//!    error is lower than the QuadGraph's, with no bake;
//! 3. an environment light -> **quadgraph**: the dipole and the voxel method see the environment
//!    as a flat irradiance (semi-infinite slab, one injected q); the QuadGraph's diffusion closes
//!    the solid and is near the path tracer;
//! 4. the object deforms (no topology change) -> **quadgraph**: it deforms its baked graph on the
//!    GPU; the dipole relinks on the CPU after each deformation (seconds on large meshes, or
//!    spread over frames in its incremental mode);
//! 5. otherwise (homogeneous, delta lights only, rigid) -> **dipole**: the lowest image error on
//!    the directly lit references and the cheapest frame once linked.
//!
//! ```
//! use translucent::frame::{choose_method, MethodKind, SceneTraits};
//! let choice = choose_method(&SceneTraits { heterogeneous: true, ..SceneTraits::default() });
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
            MethodKind::Voxel,
            "heterogeneous material: the dipole refuses it; voxel beat quadgraph on the heterogeneous reference",
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
            MethodKind::Dipole,
            "homogeneous, rigid, delta lights only: the dipole has the lowest error on directly lit references",
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
        assert_eq!(pick(rigid), MethodKind::Dipole);
        let env = SceneTraits {
            environment: true,
            ..rigid
        };
        assert_eq!(pick(env), MethodKind::QuadGraph);
        let het = SceneTraits {
            heterogeneous: true,
            ..rigid
        };
        assert_eq!(pick(het), MethodKind::Voxel);
        // A heterogeneous material under an environment: rule 2 comes before rule 3.
        assert_eq!(
            pick(SceneTraits {
                environment: true,
                ..het
            }),
            MethodKind::Voxel
        );
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
