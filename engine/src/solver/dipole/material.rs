//! Materials for the dipole method. The dipole BSSRDF is the exact solution of one homogeneous
//! half-space (paper section 2.2): a [`MaterialField::Homogeneous`] material is used as it is.
//! A heterogeneous field is either refused with [`DipoleError::Heterogeneous`], which names the
//! methods that model it ([`HeterogeneousPolicy::Refuse`], the default), or rendered "texture only"
//! ([`HeterogeneousPolicy::TextureOnly`], the paper's section 2.2 and Jensen et al. 2001): light is
//! transported through one homogeneous material, the field's mean over the surface, and the
//! exitance at each vertex is multiplied by the ratio of the local material's total diffuse
//! reflectance to the mean's. Colours and veins then show on the surface like a texture; light does
//! not bleed differently through different parts (no veins seen through the volume, no shadowing
//! by inclusions): for that use the QuadGraph method.
//!
//! ```
//! use translucent::material::{Material, MaterialField, Procedural};
//! use translucent::mesh::shapes::Shape;
//! use translucent::solver::dipole::{BoundaryModel, DipoleError, DipoleMaterial, HeterogeneousPolicy};
//! let mesh = Shape::Sphere { radius: 10.0 }.triangulate(8);
//! let marble = Material::preset("marble")?;
//! let split = MaterialField::procedural(
//!     Procedural::Split { normal: glam::DVec3::Y, offset: 0.0,
//!         below: marble.coefficients(), above: Material::preset("ketchup")?.coefficients() },
//!     1.3,
//! )?;
//! let refused = DipoleMaterial::from_field(&split, &mesh, BoundaryModel::Moments, HeterogeneousPolicy::Refuse);
//! assert!(matches!(refused, Err(DipoleError::Heterogeneous { .. })));
//! let textured = DipoleMaterial::from_field(&split, &mesh, BoundaryModel::Moments, HeterogeneousPolicy::TextureOnly)?;
//! assert_eq!(textured.modulation.as_ref().map(Vec::len), Some(mesh.positions.len()));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::profile::{BoundaryModel, DipoleProfile};
use super::DipoleError;
use crate::material::{Material, MaterialField};
use crate::mesh::TriMesh;

/// What the dipole method does with a heterogeneous material (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum HeterogeneousPolicy {
    /// A typed error naming the methods that model heterogeneous materials.
    #[default]
    Refuse,
    /// Homogeneous transport, the field as a surface texture on the exitance.
    TextureOnly,
}

/// The material the dipole method renders with.
#[derive(Clone, Debug, PartialEq)]
pub struct DipoleMaterial {
    /// The homogeneous material the light is transported through.
    pub base: Material,
    pub profile: DipoleProfile,
    /// Per display vertex and channel: the texture factor on the exitance (texture-only mode).
    pub modulation: Option<Vec<[f64; 3]>>,
}

impl DipoleMaterial {
    /// A homogeneous material.
    pub fn homogeneous(material: &Material, model: BoundaryModel) -> DipoleMaterial {
        DipoleMaterial {
            base: *material,
            profile: DipoleProfile::new(material, model),
            modulation: None,
        }
    }

    /// The material for `field` on the display mesh `mesh` (normalized, mm), by `policy`.
    pub fn from_field(
        field: &MaterialField,
        mesh: &TriMesh,
        model: BoundaryModel,
        policy: HeterogeneousPolicy,
    ) -> Result<DipoleMaterial, DipoleError> {
        let kind = match field {
            MaterialField::Homogeneous(m) => return Ok(Self::homogeneous(m, model)),
            MaterialField::Procedural { .. } => "a procedural field",
            MaterialField::Grid { .. } => "a .vol grid",
        };
        if policy == HeterogeneousPolicy::Refuse {
            return Err(DipoleError::Heterogeneous { kind });
        }
        // The field at the vertices, and its area-weighted mean over the surface.
        let samples: Vec<_> = mesh.positions.iter().map(|&p| field.sample(p)).collect();
        let mut weight = vec![0.0; mesh.positions.len()];
        for &[a, b, c] in &mesh.indices {
            let [pa, pb, pc] = [a, b, c].map(|i| mesh.positions[i as usize]);
            let third = (pb - pa).cross(pc - pa).length() / 6.0;
            for i in [a, b, c] {
                weight[i as usize] += third;
            }
        }
        let total: f64 = weight.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return Err(DipoleError::Invalid(
                "texture-only material: the mesh has no area".into(),
            ));
        }
        let mut sigma_s = [0.0; 3];
        let mut sigma_a = [0.0; 3];
        for (s, w) in samples.iter().zip(&weight) {
            for c in 0..3 {
                sigma_s[c] += s.sigma_s[c] * w / total;
                sigma_a[c] += s.sigma_a[c] * w / total;
            }
        }
        let base = Material::new(sigma_s, sigma_a, field.eta())?;
        let profile = DipoleProfile::new(&base, model);
        let base_total = profile.total_reflectance();
        let modulation = samples
            .iter()
            .map(|s| {
                let local = Material::new(s.sigma_s, s.sigma_a, base.eta)?;
                let t = DipoleProfile::new(&local, model).total_reflectance();
                Ok(std::array::from_fn(|c| {
                    if base_total[c] > 0.0 {
                        t[c] / base_total[c]
                    } else {
                        1.0
                    }
                }))
            })
            .collect::<Result<Vec<[f64; 3]>, DipoleError>>()?;
        Ok(DipoleMaterial {
            base,
            profile,
            modulation: Some(modulation),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Procedural;
    use crate::mesh::shapes::Shape;
    use glam::DVec3;

    #[test]
    fn texture_only_brightens_the_more_scattering_half_and_keeps_a_uniform_field_at_one() {
        let mesh = Shape::Sphere { radius: 10.0 }.triangulate(12);
        let marble = Material::preset("marble").unwrap();
        let ketchup = Material::preset("ketchup").unwrap();
        let split = MaterialField::procedural(
            Procedural::Split {
                normal: DVec3::Y,
                offset: 0.0,
                below: marble.coefficients(),
                above: ketchup.coefficients(),
            },
            1.3,
        )
        .unwrap();
        let m = DipoleMaterial::from_field(
            &split,
            &mesh,
            BoundaryModel::Moments,
            HeterogeneousPolicy::TextureOnly,
        )
        .unwrap();
        let t = m.modulation.unwrap();
        let (below, above) = mesh.positions.iter().zip(&t).fold(
            ([0.0f64; 2], [0.0f64; 2]),
            |(mut b, mut a), (p, m)| {
                if p.y < -1.0 {
                    b[0] += m[2];
                    b[1] += 1.0;
                } else if p.y > 1.0 {
                    a[0] += m[2];
                    a[1] += 1.0;
                }
                (b, a)
            },
        );
        // Ketchup's blue channel absorbs: darker above, brighter below than the mean.
        assert!(below[0] / below[1] > 1.0 && above[0] / above[1] < 1.0);
        // A "heterogeneous" field that is the same everywhere modulates by exactly 1.
        let uniform = MaterialField::procedural(
            Procedural::Split {
                normal: DVec3::Y,
                offset: 0.0,
                below: marble.coefficients(),
                above: marble.coefficients(),
            },
            1.3,
        )
        .unwrap();
        let u = DipoleMaterial::from_field(
            &uniform,
            &mesh,
            BoundaryModel::Jensen,
            HeterogeneousPolicy::TextureOnly,
        )
        .unwrap();
        for m in u.modulation.unwrap() {
            assert!(m.iter().all(|v| (v - 1.0).abs() < 1e-12), "{m:?}");
        }
        let e = DipoleMaterial::from_field(
            &split,
            &mesh,
            BoundaryModel::Moments,
            HeterogeneousPolicy::Refuse,
        )
        .unwrap_err();
        assert!(e.to_string().contains("quadgraph"), "{e}");
    }
}
