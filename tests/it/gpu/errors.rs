//! The GPU backend's error paths: each failure names its cause (`GpuError`'s variants) and
//! leaves no Vulkan object behind. Run under the validation layer, which reports every object
//! still alive when the device is destroyed (`vkDestroyDevice`), so a leak on an error path
//! counts as a validation message.

use isoview::gpu::{
    validation_messages, vk, Binding, Buffer, ComputePipeline, Context, ContextOptions, GpuError,
    Image3d, MemoryLocation, Resource,
};
use isoview::shaders;

fn validated() -> std::sync::Arc<Context> {
    Context::new(&ContextOptions { device: None, validation: true })
        .expect("Vulkan with VK_LAYER_KHRONOS_validation (apt-get install vulkan-validationlayers)")
}

#[gpu_test]
fn failed_constructors_name_their_cause_and_leak_nothing() {
    let ctx = validated();
    let before = validation_messages();
    let storage = vk::BufferUsageFlags::STORAGE_BUFFER;

    // More memory than the device has: the buffer is created, its allocation fails.
    let heap = ctx.info.device_local_heap.max(ctx.info.max_memory_allocation_size);
    let huge = Buffer::new(&ctx, "huge", heap + (1 << 30), storage, MemoryLocation::GpuOnly);
    assert!(
        matches!(huge, Err(GpuError::Alloc { .. }) | Err(GpuError::Vk { .. })),
        "{:?}",
        huge.err()
    );

    // Bytes that are not SPIR-V: a bug in the caller, nothing created.
    let e = ComputePipeline::new(&ctx, "broken", &[3, 2, 35, 7, 0], &[], 0).err().unwrap();
    assert!(matches!(e, GpuError::Bug(_)), "{e:?}");
    assert_eq!(
        e.to_string(),
        "internal error (a bug in isoview): shader `broken` is not SPIR-V: \
         input length not divisible by 4"
    );

    // A grid over the device's 3D image limit: too large, nothing created.
    let max = ctx.info.max_image_dimension_3d;
    let e = Image3d::upload(&ctx, "grid", [max + 1, 1, 1], &[]).err().unwrap();
    assert!(matches!(e, GpuError::TooLarge { .. }), "{e:?}");
    assert_eq!(
        e.to_string(),
        format!(
            "a grid of {}x1x1 points does not fit the device's 3D images (at most {max} points \
             per axis)",
            max + 1
        )
    );
    let e = Image3d::upload(&ctx, "grid", [2, 2, 2], &[0.0; 7]).err().unwrap();
    assert!(matches!(e, GpuError::Bug(_)), "{e:?}");

    // Wrong bindings: refused before the descriptor pool exists.
    let pipeline = ComputePipeline::new(
        &ctx,
        "layout probe",
        shaders::TEST_LAYOUT_PROBE,
        &[Binding::Uniform, Binding::Write, Binding::Write],
        0,
    )
    .unwrap();
    let b = Buffer::new(&ctx, "b", 256, storage, MemoryLocation::GpuToCpu).unwrap();
    let e = pipeline.bind(&[Resource::Storage(&b)]).err().unwrap();
    assert!(matches!(e, GpuError::Bug(_)), "{e:?}");
    let e = pipeline
        .bind(&[Resource::Storage(&b), Resource::Storage(&b), Resource::Storage(&b)])
        .err()
        .unwrap();
    assert!(matches!(e, GpuError::Bug(_)), "{e:?}");
    assert!(
        e.to_string().contains("binding 0 is Uniform (UNIFORM_BUFFER), got STORAGE_BUFFER"),
        "{e}"
    );
    let e = b.read::<u32>(65).err().unwrap();
    assert!(matches!(e, GpuError::Bug(_)), "{e:?}");

    drop((pipeline, b));
    drop(ctx);
    assert_eq!(validation_messages(), before, "validation messages or leaks (printed above)");
}

#[gpu_test]
fn a_device_that_is_not_there_leaves_no_instance_behind() {
    let before = validation_messages();
    let options = ContextOptions { device: Some("no such device".into()), validation: true };
    let e = Context::new(&options).err().unwrap();
    assert!(matches!(e, GpuError::DeviceNotFound { .. }), "{e:?}");
    assert!(e.to_string().starts_with("no Vulkan device matches \"no such device\""), "{e}");
    assert_eq!(validation_messages(), before, "validation messages (printed above)");
}
