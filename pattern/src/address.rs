//! Where a display's patterns go: `tcp://HOST:PORT/OUTPUT`, an output of the pattern
//! server on a render node.

use std::fmt;
use std::str::FromStr;

use crate::limits::valid_name;

/// A render node's pattern server and one of its outputs.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct OutputAddress {
    /// Host name or IP address (an IPv6 address in brackets).
    pub host: String,
    /// TCP port.
    pub port: u16,
    /// The output's name on that node (`DP-1`, `0`, ...).
    pub output: String,
}

impl OutputAddress {
    /// The node, `HOST:PORT`.
    pub fn node(&self) -> String {
        format!("{}:{}", self.host, self.port)
    }

    /// The gRPC endpoint URI of the node.
    pub fn endpoint_uri(&self) -> String {
        format!("http://{}:{}", self.host, self.port)
    }
}

impl fmt::Display for OutputAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "tcp://{}:{}/{}", self.host, self.port, self.output)
    }
}

/// An output address that does not parse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "{given:?} is not an output address: {reason} (expected tcp://HOST:PORT/OUTPUT, e.g. tcp://node03:50051/DP-1)"
)]
pub struct AddressError {
    /// What was given.
    pub given: String,
    /// What is wrong.
    pub reason: &'static str,
}

impl FromStr for OutputAddress {
    type Err = AddressError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = |reason| AddressError {
            given: s.to_string(),
            reason,
        };
        let rest = s
            .strip_prefix("tcp://")
            .ok_or_else(|| bad("it must start with tcp://"))?;
        let (authority, output) = rest
            .split_once('/')
            .ok_or_else(|| bad("the output name after the port is missing"))?;
        let (host, port) = authority
            .rsplit_once(':')
            .ok_or_else(|| bad("the port is missing"))?;
        let port: u16 = port
            .parse()
            .map_err(|_| bad("the port is not a number 1..65535"))?;
        if port == 0 {
            return Err(bad("the port is not a number 1..65535"));
        }
        let host_ok = !host.is_empty()
            && (host.starts_with('[') && host.ends_with(']')
                || host
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '.'));
        if !host_ok {
            return Err(bad("the host is not a host name or IP address"));
        }
        if !valid_name(output) {
            return Err(bad(
                "the output name must be 1 to 64 letters, digits or -_.:@",
            ));
        }
        Ok(OutputAddress {
            host: host.to_string(),
            port,
            output: output.to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_parse_and_print_back() {
        let a: OutputAddress = "tcp://node03.wall:50051/DP-1".parse().unwrap();
        assert_eq!(a.node(), "node03.wall:50051");
        assert_eq!(a.output, "DP-1");
        assert_eq!(a.to_string(), "tcp://node03.wall:50051/DP-1");
        let v6: OutputAddress = "tcp://[::1]:7000/0".parse().unwrap();
        assert_eq!(v6.endpoint_uri(), "http://[::1]:7000");
        for bad in [
            "node:1/0",
            "tcp://node/0",
            "tcp://node:0/0",
            "tcp://node:70000/0",
            "tcp://node:1",
            "tcp://node:1/",
            "tcp://no de:1/0",
            "tcp://node:1/a b",
        ] {
            assert!(bad.parse::<OutputAddress>().is_err(), "{bad}");
        }
    }
}
