//! Runtime recompilation of GLSL (opt-in feature `hot-reload`; builds libshaderc from source).
//! The result goes through the same [`super::Reflection`] checks as embedded shaders.

use super::{ShaderError, Spirv};

/// Compiles `path` (a `.comp`, `.vert` or `.frag` file) with the same options as `build.rs`.
pub fn compile_file(
    path: &std::path::Path,
    include_dir: &std::path::Path,
) -> Result<Spirv, ShaderError> {
    let name = path.display().to_string();
    let invalid = |message: String| ShaderError::Invalid {
        shader: name.clone(),
        message,
    };
    let source = std::fs::read_to_string(path).map_err(|e| invalid(e.to_string()))?;
    let kind = match path.extension().and_then(|e| e.to_str()) {
        Some("comp") => shaderc::ShaderKind::Compute,
        Some("vert") => shaderc::ShaderKind::Vertex,
        Some("frag") => shaderc::ShaderKind::Fragment,
        _ => return Err(invalid("extension must be .comp, .vert or .frag".into())),
    };
    let compiler = shaderc::Compiler::new().map_err(|e| invalid(format!("shaderc: {e}")))?;
    let mut options =
        shaderc::CompileOptions::new().map_err(|e| invalid(format!("shaderc: {e}")))?;
    options.set_target_env(
        shaderc::TargetEnv::Vulkan,
        shaderc::EnvVersion::Vulkan1_3 as u32,
    );
    options.set_optimization_level(shaderc::OptimizationLevel::Performance);
    // Reflection looks bindings up by name (as `build.rs` passes `-g`).
    options.set_generate_debug_info();
    let include_dir = include_dir.to_path_buf();
    options.set_include_callback(move |requested, _, _, _| {
        let full = include_dir.join(requested);
        let content =
            std::fs::read_to_string(&full).map_err(|e| format!("{}: {e}", full.display()))?;
        Ok(shaderc::ResolvedInclude {
            resolved_name: full.display().to_string(),
            content,
        })
    });
    let artifact = compiler
        .compile_into_spirv(&source, kind, &name, "main", Some(&options))
        .map_err(|e| invalid(e.to_string()))?;
    Ok(Spirv {
        name,
        words: artifact.as_binary().to_vec(),
    })
}
