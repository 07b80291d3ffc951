//! Scene input in one test program: meshes, photometric files and scene files.

mod mesh_tests;
mod photometry_tests;
mod scene_inputs;
