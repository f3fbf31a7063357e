//! GPU round trip of the structs shared with GLSL: what the shader sees of `RenderParams`, and
//! where its writes of `Pixel` land. Output buffers start filled with a sentinel so a member
//! the shader never wrote differs from one written as 0.

use isoview::frame::Pixel;
use isoview::gpu::{vk, Buffer, ComputePipeline, MemoryLocation, Resource};
use isoview::render::params::RenderParams;
use isoview::shaders;

use crate::common::gpu;

const SENTINEL: u32 = 0xDEAD_BEEF;

#[test]
#[cfg_attr(isoview_skip_gpu, ignore = "GPU test: ISOVIEW_SKIP_GPU_TESTS=1")]
fn shared_structs_have_the_same_layout_on_the_gpu() {
    let ctx = gpu();
    let mut params = RenderParams::default();
    // Distinct bits in every 4-byte slot.
    let words: &mut [u32] = bytemuck::cast_slice_mut(std::slice::from_mut(&mut params));
    for (i, w) in words.iter_mut().enumerate() {
        *w = 0x4000_0000 + i as u32 * 7919;
    }
    let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::UNIFORM_BUFFER;
    let bytes = std::mem::size_of::<RenderParams>() as u64;
    let words = bytes as usize / 4;
    let mut ubo =
        Buffer::new(&ctx, "probe params", bytes, usage, MemoryLocation::CpuToGpu).unwrap();
    ubo.write(std::slice::from_ref(&params)).unwrap();
    let mut bits = Buffer::new(&ctx, "probe bits", bytes, usage, MemoryLocation::GpuToCpu).unwrap();
    bits.write(&vec![SENTINEL; words]).unwrap();
    let mut px = Buffer::new(&ctx, "probe pixels", 128, usage, MemoryLocation::GpuToCpu).unwrap();
    px.write(&[SENTINEL; 32]).unwrap();

    let pipeline = ComputePipeline::new(
        &ctx,
        "layout probe",
        shaders::TEST_LAYOUT_PROBE,
        &[
            vk::DescriptorType::UNIFORM_BUFFER,
            vk::DescriptorType::STORAGE_BUFFER,
            vk::DescriptorType::STORAGE_BUFFER,
        ],
        0,
    )
    .unwrap();
    let set = pipeline
        .bind(&[Resource::Uniform(&ubo), Resource::Storage(&bits), Resource::Storage(&px)])
        .unwrap();
    ctx.submit("layout probe", |cmd| {
        pipeline.record(cmd, &set, &[], [1, 1, 1]);
        Ok(())
    })
    .unwrap();

    let seen: Vec<u32> = bits.read(words).unwrap();
    let sent: &[u32] = bytemuck::cast_slice(std::slice::from_ref(&params));
    assert_eq!(seen, sent, "RenderParams as GLSL reads it");

    let pixels: Vec<Pixel> = px.read(2).unwrap();
    let untouched: &[u32] = bytemuck::cast_slice(std::slice::from_ref(&pixels[0]));
    assert!(untouched.iter().all(|&w| w == SENTINEL), "pixel 0 must stay unwritten");
    assert_eq!(
        pixels[1],
        Pixel {
            rgba: [1.0, 2.0, 3.0, 4.0],
            normal: [5.0, 6.0, 7.0],
            depth: 8.0,
            position: [9.0, 10.0, 11.0],
            steps: 12.0,
            cell: [13, 14, 15],
            crossings: 16,
        }
    );
}
