//! What a pattern server serves: its outputs, address, token and settle time.

use std::net::SocketAddr;
use std::str::FromStr;
use std::time::Duration;

use crate::framebuffer::size_ok;
use crate::limits::{MAX_OUTPUTS, MAX_SETTLE, valid_name};
use crate::proto;
use crate::token::Token;

/// One output of the node: `NAME=WIDTHxHEIGHT@BITS` or `NAME=WIDTHxHEIGHT@BITS/SURFACE`
/// (e.g. `DP-1=1920x1200@10/8`: a 10-bit display behind an 8-bit surface).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutputSpec {
    /// Name the wall file uses.
    pub name: String,
    /// Width in pixels.
    pub width_px: u32,
    /// Height in pixels.
    pub height_px: u32,
    /// Bits per channel of the display input (what the station sends).
    pub bit_depth: u32,
    /// Bits per channel of the presented surface.
    pub surface_bit_depth: u32,
}

impl OutputSpec {
    /// The output as the protocol describes it.
    pub fn to_proto(&self) -> proto::Output {
        proto::Output {
            name: self.name.clone(),
            width_px: self.width_px,
            height_px: self.height_px,
            bit_depth: self.bit_depth,
            surface_bit_depth: self.surface_bit_depth,
        }
    }
}

impl FromStr for OutputSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let bad = |why: &str| {
            format!(
                "{s:?}: {why} (expected NAME=WIDTHxHEIGHT@BITS[/SURFACE_BITS], e.g. DP-1=1920x1200@10)"
            )
        };
        let (name, rest) = s.split_once('=').ok_or_else(|| bad("no '='"))?;
        if !valid_name(name) {
            return Err(bad("the name must be 1 to 64 letters, digits or -_.:@"));
        }
        let (size, bits) = rest.split_once('@').ok_or_else(|| bad("no '@BITS'"))?;
        let (w, h) = size
            .split_once('x')
            .ok_or_else(|| bad("the size is not WxH"))?;
        let (bits, surface) = match bits.split_once('/') {
            Some((b, s)) => (b, Some(s)),
            None => (bits, None),
        };
        let num = |v: &str| v.parse::<u32>().map_err(|_| bad("not a number"));
        let (width_px, height_px, bit_depth) = (num(w)?, num(h)?, num(bits)?);
        let surface_bit_depth = surface.map(num).transpose()?.unwrap_or(bit_depth);
        if !size_ok(width_px, height_px) {
            return Err(bad(
                "the size is 0 or beyond 16384 a side / 8192×8192 pixels",
            ));
        }
        if !(1..=16).contains(&bit_depth) || !(1..=16).contains(&surface_bit_depth) {
            return Err(bad("bit depths are 1 to 16"));
        }
        Ok(OutputSpec {
            name: name.to_string(),
            width_px,
            height_px,
            bit_depth,
            surface_bit_depth,
        })
    }
}

/// Everything a pattern server runs with.
#[derive(Debug, Clone)]
pub struct ServerConfig {
    /// The one address it binds to.
    pub listen: SocketAddr,
    /// The wall's token.
    pub token: Token,
    /// Its outputs.
    pub outputs: Vec<OutputSpec>,
    /// Wait after presenting before answering (projector processing, LCD response).
    pub settle: Duration,
    /// The node's name in messages (its host name).
    pub node_name: String,
    /// TLS: the node's certificate chain and private key (PEM). `None`: plain TCP
    /// (the token then travels in clear: use it only on a closed wall network).
    pub tls: Option<TlsIdentity>,
}

/// A node's TLS identity, PEM.
#[derive(Clone)]
pub struct TlsIdentity {
    /// Certificate chain, PEM.
    pub cert_pem: Vec<u8>,
    /// Private key, PEM.
    pub key_pem: Vec<u8>,
}

impl std::fmt::Debug for TlsIdentity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("TlsIdentity(<hidden>)")
    }
}

impl ServerConfig {
    /// Checks the outputs (1 to 16, unique names) and the settle time.
    pub fn validate(&self) -> Result<(), String> {
        if self.outputs.is_empty() || self.outputs.len() > MAX_OUTPUTS {
            return Err(format!(
                "{} outputs configured; a node serves 1 to {MAX_OUTPUTS}",
                self.outputs.len()
            ));
        }
        for (i, o) in self.outputs.iter().enumerate() {
            if self.outputs[..i].iter().any(|p| p.name == o.name) {
                return Err(format!("output name {:?} is given twice", o.name));
            }
        }
        if self.settle > MAX_SETTLE {
            return Err(format!(
                "settle time {:?} is longer than {MAX_SETTLE:?}",
                self.settle
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn output_specs_parse_with_and_without_a_surface_depth() {
        let o: OutputSpec = "DP-1=1920x1200@10/8".parse().unwrap();
        assert_eq!(
            (o.width_px, o.height_px, o.bit_depth, o.surface_bit_depth),
            (1920, 1200, 10, 8)
        );
        let o: OutputSpec = "0=64x40@8".parse().unwrap();
        assert_eq!(o.surface_bit_depth, 8);
        for bad in [
            "DP-1",
            "=1x1@8",
            "a=0x1@8",
            "a=1x1@17",
            "a=99999x1@8",
            "a=1x1@8/0",
            "a b=1x1@8",
        ] {
            assert!(bad.parse::<OutputSpec>().is_err(), "{bad}");
        }
    }
}
