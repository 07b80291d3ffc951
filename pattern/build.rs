//! Compiles `proto/lumiwall/pattern/v1/pattern.proto` with `protox` (a protobuf
//! compiler in Rust, so no system `protoc` is needed) and generates the tonic client
//! and server.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let proto = "proto/lumiwall/pattern/v1/pattern.proto";
    println!("cargo:rerun-if-changed={proto}");
    let descriptors = protox::compile([proto], ["proto"])?;
    tonic_prost_build::configure()
        .build_client(true)
        .build_server(true)
        .compile_fds(descriptors)?;
    Ok(())
}
