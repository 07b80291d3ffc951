//! The post pass's tests in one test program: GPU against CPU, and image I/O.

mod post_support;

mod post_gpu_cpu;
mod post_io;
