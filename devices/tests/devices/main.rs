//! The device layer's tests in one test program (linking one is most of a test
//! program's build time): serial protocols and emulators, the virtual wall's physics,
//! meters and cameras. The parser fuzzing stays a program of its own.

mod serial_k10a;
mod serial_protocol;
mod serial_sim;
mod serial_specbos;
mod sim_meter;
mod sim_observer;
mod sim_physics;
mod sim_wall_limits;
mod sim_walls;
mod uvc_camera;
mod virtual_camera;
