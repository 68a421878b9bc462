//! The frame graph places the barriers between passes from their declarations (issue 11 item 7):
//! a pass that reads what an earlier pass wrote without declaring it is caught by synchronization
//! validation, and the same two passes declared in full are silent.
//!
//! lavapipe executes serially, so both variants give the same bytes: only synchronization
//! validation tells them apart, which is why every GPU test keeps it on.

use ash::vk;
use translucent::frame::FrameGraph;
use translucent::vk::barrier::Use;
use translucent::vk::{Access, Buffer, BufferDesc, Context, MemoryUse};
use translucent_tests::GpuTest;

const BYTES: u64 = 4096;

fn buffer(ctx: &Context, name: &'static str) -> Buffer {
    Buffer::new(
        ctx,
        &BufferDesc {
            name,
            size: BYTES,
            usage: vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST,
            memory: MemoryUse::GpuOnly,
        },
    )
    .expect("buffer")
}

/// Pass `fill` writes `src`; pass `copy` copies `src` into `dst`. With `declare_src` false the
/// copy does not declare that it reads `src`, so the graph places no barrier for it.
/// Returns the barrier notes the graph recorded.
fn fill_then_copy(ctx: &Context, declare_src: bool) -> Vec<translucent::frame::BarrierNote> {
    let src = buffer(ctx, "src");
    let dst = buffer(ctx, "dst");
    let mut notes = Vec::new();
    ctx.execute("fill then copy", |cb| {
        let mut graph = FrameGraph::new(ctx);
        graph
            .pass("fill")
            .uses([Use::buffer(&src, Access::TransferDst)])
            .record(|p| {
                // SAFETY: inside a pass declaring `src` as a transfer destination.
                unsafe {
                    p.ctx
                        .raw()
                        .cmd_fill_buffer(p.cb, src.raw, 0, BYTES, 0x3f80_0000)
                };
                Ok(())
            });
        let mut uses = vec![Use::buffer(&dst, Access::TransferDst)];
        if declare_src {
            uses.push(Use::buffer(&src, Access::TransferSrc));
        }
        graph.pass("copy").uses(uses).record(|p| {
            let region = vk::BufferCopy {
                src_offset: 0,
                dst_offset: 0,
                size: BYTES,
            };
            // SAFETY: inside a pass declaring `dst` (and, when asked, `src`).
            unsafe {
                p.ctx
                    .raw()
                    .cmd_copy_buffer(p.cb, src.raw, dst.raw, &[region])
            };
            Ok(())
        });
        // SAFETY: `cb` is recording outside a rendering scope; the buffers outlive the wait.
        let run = unsafe { graph.execute(cb, None, false) }.expect("graph");
        assert_eq!(run.passes, ["fill", "copy"]);
        notes = run.barriers;
        Ok(())
    })
    .expect("submission");
    notes
}

#[test]
fn a_missing_declaration_is_caught_by_synchronization_validation() {
    let gpu = GpuTest::new();
    let notes = fill_then_copy(&gpu.ctx, false);
    assert!(
        !notes
            .iter()
            .any(|n| n.resource == "src" && n.before == "copy"),
        "no declaration, no barrier: {notes:?}"
    );
    let messages = gpu.ctx.validation_log().take();
    assert!(
        messages
            .iter()
            .any(|m| m.to_string().contains("READ_AFTER_WRITE")),
        "synchronization validation should report the copy reading `src` after the fill without a barrier; got {} message(s): {:?}",
        messages.len(),
        messages.iter().map(|m| m.to_string()).collect::<Vec<_>>()
    );
    gpu.finish();
}

#[test]
fn the_graphs_barriers_make_the_same_passes_silent() {
    let gpu = GpuTest::new();
    let notes = fill_then_copy(&gpu.ctx, true);
    let note = notes
        .iter()
        .find(|n| n.resource == "src" && n.before == "copy")
        .unwrap_or_else(|| panic!("a barrier for src before copy: {notes:?}"));
    assert!(note.hazard.contains("RAW"), "{note:?}");
    assert!(
        note.why.contains("fill") && note.why.contains("copy"),
        "the why names both passes: {note:?}"
    );
    gpu.finish();
}
