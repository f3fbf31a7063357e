//! Comparison of float EXR images (`isoview compare`).
