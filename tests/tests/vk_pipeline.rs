//! Pipeline creation checks the Rust side (push-constant struct size, binding names and types)
//! against the shader's reflection and returns typed errors.

use ash::vk;
use translucent::render::JacobiPush;
use translucent::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite, ShaderError};
use translucent::vk::{Buffer, BufferDesc, Image, ImageDesc, MemoryUse};
use translucent_tests::GpuTest;

fn desc<'a>(bindings: &'a [&'a str]) -> ComputePipelineDesc<'a> {
    ComputePipelineDesc {
        name: "checked",
        shader: "laplace/jacobi_step.comp",
        bindings,
        max_sets: 1,
    }
}

#[test]
fn mismatches_between_rust_and_shader_are_typed_errors() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    // The shader's JacobiPush is an ivec2 (8 bytes); 16 bytes must be refused.
    match ComputePipeline::<[f32; 4]>::new(ctx, &desc(&["src", "dst"])) {
        Err(ShaderError::PushConstantSize {
            rust: 16,
            reflected: 8,
            ..
        }) => {}
        other => panic!("expected PushConstantSize, got {:?}", other.err()),
    }
    assert!(matches!(
        ComputePipeline::<JacobiPush>::new(ctx, &desc(&["src", "dst", "extra"])),
        Err(ShaderError::UnknownBinding { .. })
    ));
    assert!(matches!(
        ComputePipeline::<JacobiPush>::new(ctx, &desc(&["src"])),
        Err(ShaderError::UnboundBinding { .. })
    ));
    let missing = ComputePipelineDesc {
        shader: "laplace/missing.comp",
        ..desc(&[])
    };
    assert!(matches!(
        ComputePipeline::<JacobiPush>::new(ctx, &missing),
        Err(ShaderError::NotEmbedded { .. })
    ));

    let pipeline =
        ComputePipeline::<JacobiPush>::new(ctx, &desc(&["src", "dst"])).expect("matching pipeline");
    assert_eq!(pipeline.workgroup_size, [8, 8, 1]);
    let image = Image::new(
        ctx,
        &ImageDesc {
            name: "img",
            width: 4,
            height: 4,
            format: vk::Format::R16G16B16A16_SFLOAT,
            usage: vk::ImageUsageFlags::STORAGE,
        },
    )
    .expect("image");
    let buffer = Buffer::new(
        ctx,
        &BufferDesc {
            name: "buf",
            size: 64,
            usage: vk::BufferUsageFlags::STORAGE_BUFFER,
            memory: MemoryUse::Upload,
        },
    )
    .expect("buffer");
    let wrong_type = pipeline.allocate_set(
        ctx,
        &[
            DescriptorWrite::storage_image("src", &image),
            DescriptorWrite::StorageBuffer {
                name: "dst",
                buffer: &buffer,
            },
        ],
    );
    assert!(
        matches!(wrong_type, Err(ShaderError::BindingType { .. })),
        "{:?}",
        wrong_type.err()
    );
    let incomplete = pipeline.allocate_set(ctx, &[DescriptorWrite::storage_image("src", &image)]);
    assert!(matches!(
        incomplete,
        Err(ShaderError::UnboundBinding { .. })
    ));
    let error_text = ComputePipeline::<[f32; 4]>::new(ctx, &desc(&["src", "dst"]))
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        error_text.contains("checked") && error_text.contains("laplace/jacobi_step.comp"),
        "{error_text}"
    );
    drop((pipeline, image, buffer));
    gpu.finish();
}
