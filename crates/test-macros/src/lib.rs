//! `#[gpu_test]`: the one declaration of a test that needs a Vulkan device (docs/contributing.md
//! "Tests"). It stands for
//!
//! ```text
//! #[test]
//! #[cfg_attr(isoview_skip_gpu, ignore = "GPU test: ISOVIEW_SKIP_GPU_TESTS=1")]
//! ```
//!
//! and `#[gpu_test(float64)]`, for a test that needs `shaderFloat64` too, adds
//!
//! ```text
//! #[cfg_attr(
//!     all(isoview_no_float64, not(isoview_skip_gpu)),
//!     ignore = "needs shaderFloat64: ISOVIEW_NO_FLOAT64_TESTS=1"
//! )]
//! ```
//!
//! The cfgs are isoview's, set by its `build.rs` from those variables; they are evaluated in
//! the crate that uses the attribute. Without them set the test runs, and fails without a
//! device (or, calling `need_float64`, without the feature); with them libtest lists it as
//! ignored, with the reason. Nothing else about the test changes. No dependencies: the
//! attributes are written as text and parsed, then the test's own tokens follow unchanged.

use proc_macro::TokenStream;

/// Declares a GPU test (see the crate docs). Arguments: none, or `float64`.
#[proc_macro_attribute]
pub fn gpu_test(args: TokenStream, item: TokenStream) -> TokenStream {
    let args = args.to_string();
    let float64 = match args.trim() {
        "" => false,
        "float64" => true,
        other => {
            let message = format!("#[gpu_test({other})]: the only argument is `float64`");
            return format!("compile_error!({message:?});").parse().unwrap();
        }
    };
    let mut attributes = String::from(
        "#[test] #[cfg_attr(isoview_skip_gpu, ignore = \"GPU test: ISOVIEW_SKIP_GPU_TESTS=1\")]",
    );
    if float64 {
        // Not also under isoview_skip_gpu: one `ignore` per test (a second is a warning).
        attributes.push_str(
            "#[cfg_attr(all(isoview_no_float64, not(isoview_skip_gpu)), \
             ignore = \"needs shaderFloat64: ISOVIEW_NO_FLOAT64_TESTS=1\")]",
        );
    }
    let mut out: TokenStream = attributes.parse().expect("the attributes are valid tokens");
    out.extend(item);
    out
}
