//! What the camera tests share.

use lumiwall_devices::sim::VirtualWall;

/// The fixture wall `name` (`fixtures/walls/NAME.toml`) with `extra` TOML appended.
pub(crate) fn wall(name: &str, extra: &str) -> VirtualWall {
    let path = format!(
        "{}/../fixtures/walls/{name}.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(path).expect("fixture");
    VirtualWall::from_toml_str(&format!("{text}\n{extra}")).expect("wall")
}
