//! Where data files (reference meshes) are found: a config's own folder first, then the
//! folder named by the `SOFTBENCH_DATA` environment variable.
