//! Embedded SPIR-V (compiled by `build.rs` with glslc), its reflection (spirq) and pipelines that
//! check the Rust side against it.
//!
//! Every `shaders-glsl/<pass>/<verb_noun>.{comp,vert,frag}` is embedded under its relative path.
//! A pipeline is created from shader names, the Rust push-constant type and the binding names the
//! Rust side will write; each is checked against the reflection and a mismatch is a typed
//! [`ShaderError`], never a validation error at draw time.
//!
//! ```no_run
//! use translucent::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite};
//! #[repr(C)]
//! #[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
//! struct JacobiPush { size: [i32; 2] }
//! # fn f(ctx: &translucent::vk::Context, a: &translucent::vk::Image, b: &translucent::vk::Image) -> Result<(), translucent::shader::ShaderError> {
//! let pipeline = ComputePipeline::<JacobiPush>::new(ctx, &ComputePipelineDesc {
//!     name: "jacobi step",
//!     shader: "laplace/jacobi_step.comp",
//!     bindings: &["src", "dst"],
//!     max_sets: 2,
//! })?;
//! let a_to_b = pipeline.allocate_set(
//!     ctx,
//!     &[DescriptorWrite::storage_image("src", a), DescriptorWrite::storage_image("dst", b)],
//! )?;
//! // Recording: `unsafe { pipeline.dispatch(ctx, cb, a_to_b, &JacobiPush { size: [64, 64] }, [64, 64, 1]) }`
//! # Ok(()) }
//! ```

mod pipeline;
mod reflect;

pub mod runtime;

pub use pipeline::{
    ComputePipeline, ComputePipelineDesc, DescriptorWrite, GraphicsPipeline, GraphicsPipelineDesc,
    NoPushConstants, SpecConstant, VertexAttribute,
};
pub use reflect::{BindingInfo, Reflection};

mod embedded {
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}

/// A shader whose interface does not match the Rust side, or that cannot be found or reflected.
#[derive(Debug, thiserror::Error)]
pub enum ShaderError {
    #[error("shader {name:?} is not embedded (is it under shaders-glsl/ with a .comp/.vert/.frag extension?)")]
    NotEmbedded { name: String },
    #[error("shader {shader:?}: {message}")]
    Invalid { shader: String, message: String },
    #[error("pipeline {pipeline:?}: the Rust push-constant struct has {rust} bytes, shader {shader:?} declares {reflected}")]
    PushConstantSize {
        pipeline: &'static str,
        shader: String,
        rust: usize,
        reflected: usize,
    },
    #[error("pipeline {pipeline:?}: the Rust side binds {name:?}, which the shaders do not declare (they declare {declared:?})")]
    UnknownBinding {
        pipeline: &'static str,
        name: String,
        declared: Vec<String>,
    },
    #[error("pipeline {pipeline:?}: the shaders use binding {name:?}, which the Rust side does not bind")]
    UnboundBinding {
        pipeline: &'static str,
        name: String,
    },
    #[error("pipeline {pipeline:?}: binding {name:?} is a {declared} in the shader, the Rust side writes a {written}")]
    BindingType {
        pipeline: &'static str,
        name: String,
        declared: String,
        written: String,
    },
    #[error("pipeline {pipeline:?}: uniform buffer {name:?} has {rust} bytes, the shader's block {reflected}")]
    UniformSize {
        pipeline: &'static str,
        name: String,
        rust: u64,
        reflected: usize,
    },
    #[error("pipeline {pipeline:?}: {message}")]
    Unsupported {
        pipeline: &'static str,
        message: String,
    },
    #[error("shader compiler {program:?} cannot run ({message}): install the Debian package `glslc` (apt-get install glslc) or name it in TRANSLUCENT_GLSLC")]
    NoCompiler { program: String, message: String },
    #[error("glslc failed on {shader}:\n{message}")]
    Compile {
        shader: String,
        /// The line of glslc's first error (in the shader or a file it includes).
        line: Option<u32>,
        /// glslc's message.
        message: String,
    },
    #[error("shader source {path}: {message}")]
    Source { path: String, message: String },
    #[error(transparent)]
    Vk(#[from] crate::vk::VkError),
}

/// SPIR-V words of an embedded shader.
#[derive(Clone, Debug)]
pub struct Spirv {
    pub name: String,
    pub words: Vec<u32>,
}

/// Names of all embedded shaders.
pub fn embedded_names() -> impl Iterator<Item = &'static str> {
    embedded::EMBEDDED.iter().map(|(n, _)| *n)
}

/// The embedded shader `name` (path under `shaders-glsl/`, e.g. `"mesh/shade_mesh.frag"`).
pub fn embedded(name: &str) -> Result<Spirv, ShaderError> {
    let bytes = embedded::EMBEDDED
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, b)| *b)
        .ok_or_else(|| ShaderError::NotEmbedded { name: name.into() })?;
    Spirv::from_bytes(name, bytes)
}

/// The shader `name` for pipelines made with `ctx`: the SPIR-V the host installed for it with
/// [`crate::vk::Context::set_shader_overrides`] (hot reload, [`runtime`]), else the embedded one.
pub fn load(ctx: &crate::vk::Context, name: &str) -> Result<Spirv, ShaderError> {
    match ctx.shader_override(name) {
        Some(words) => Ok(Spirv {
            name: name.into(),
            words: words.to_vec(),
        }),
        None => embedded(name),
    }
}

impl Spirv {
    /// Words from little-endian bytes (include_bytes! gives no alignment, so they are copied).
    pub fn from_bytes(name: &str, bytes: &[u8]) -> Result<Spirv, ShaderError> {
        if bytes.len() % 4 != 0 || bytes.len() < 20 {
            return Err(ShaderError::Invalid {
                shader: name.into(),
                message: format!("{} bytes is not SPIR-V", bytes.len()),
            });
        }
        let words: Vec<u32> = bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        if words[0] != 0x0723_0203 {
            return Err(ShaderError::Invalid {
                shader: name.into(),
                message: "bad SPIR-V magic number".into(),
            });
        }
        Ok(Spirv {
            name: name.into(),
            words,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_embedded_shader_reflects_and_compute_shaders_have_a_workgroup_size() {
        let names: Vec<_> = embedded_names().collect();
        assert!(names.contains(&"laplace/jacobi_step.comp"), "{names:?}");
        for name in names {
            let r = Reflection::new(&embedded(name).expect("embedded")).expect("reflects");
            if name.ends_with(".comp") {
                assert!(r.workgroup_size.is_some(), "{name}");
            }
        }
        let jacobi = Reflection::new(&embedded("laplace/jacobi_step.comp").expect("embedded"))
            .expect("reflects");
        assert_eq!(jacobi.workgroup_size, Some([8, 8, 1]));
        assert_eq!(jacobi.push_constant_size, Some(8));
        let names: Vec<_> = jacobi
            .bindings
            .iter()
            .map(|b| (b.name.as_str(), b.binding))
            .collect();
        assert_eq!(names, vec![("src", 0), ("dst", 1)]);
        let frag = Reflection::new(&embedded("mesh/shade_mesh.frag").expect("embedded"))
            .expect("reflects");
        // ShadePush: eta, radiance_mode, roughness, specular, lobe_slope, lobe_k, lobe_own,
        // lobe_bounce.
        assert_eq!(frag.push_constant_size, Some(32));
        assert_eq!(std::mem::size_of::<crate::render::ShadePush>(), 32);
        assert!(frag.bindings.iter().any(|b| b.name == "shadow_map"
            && b.descriptor_type == ash::vk::DescriptorType::COMBINED_IMAGE_SAMPLER));
        let uniform = frag
            .bindings
            .iter()
            .find(|b| b.name == "frame")
            .and_then(|b| b.uniform_size);
        let rust = std::mem::size_of::<crate::render::ShadeUniforms>();
        assert_eq!(uniform, Some(rust), "std140 layout of ShadeUniforms");
    }

    #[test]
    fn the_diffusion_passes_declare_the_homogeneous_specialization_constant() {
        // One module per pass (DESIGN section 5): the material kind is constant_id 0, not a copy
        // of the shader compiled with a define.
        for name in [
            "diffusion/jacobi_fp16.comp",
            "diffusion/jacobi_fp32.comp",
            "diffusion/correction_sweep_mixed.comp",
            "diffusion/residual_fp32.comp",
        ] {
            let r = Reflection::new(&embedded(name).expect("embedded")).expect("reflects");
            // constant_id 1 and 2 (graph_weights.glsl): heterogeneous weights derived in the
            // sweep, and the paper scheme's harmonic means.
            assert_eq!(
                r.spec_constants,
                vec![
                    ("HOMOGENEOUS".to_string(), 0),
                    ("DERIVED".to_string(), 1),
                    ("PAPER".to_string(), 2)
                ],
                "{name}"
            );
        }
        assert!(!embedded_names().any(|n| n.ends_with("_h.comp")));
    }

    #[test]
    fn missing_and_malformed_shaders_are_typed_errors() {
        assert!(matches!(
            embedded("nope.comp"),
            Err(ShaderError::NotEmbedded { .. })
        ));
        assert!(matches!(
            Spirv::from_bytes("x", &[1, 2, 3]),
            Err(ShaderError::Invalid { .. })
        ));
        assert!(matches!(
            Spirv::from_bytes("x", &[0; 40]),
            Err(ShaderError::Invalid { .. })
        ));
    }
}
