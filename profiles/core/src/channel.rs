//! The three drive channels of a display.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::CoreError;

/// A display's drive channel. Index order (0, 1, 2) is the order of every `[_; 3]`
/// per-channel array in lumiwall.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Channel {
    /// Red, index 0.
    Red,
    /// Green, index 1.
    Green,
    /// Blue, index 2.
    Blue,
}

impl Channel {
    /// The three channels in index order.
    pub const ALL: [Channel; 3] = [Channel::Red, Channel::Green, Channel::Blue];

    /// Index 0, 1 or 2 into per-channel arrays.
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The channel of index 0, 1 or 2.
    pub fn from_index(index: usize) -> Result<Self, CoreError> {
        Self::ALL
            .get(index)
            .copied()
            .ok_or(CoreError::ChannelIndex(index))
    }

    /// Lower-case name: "red", "green", "blue".
    pub const fn name(self) -> &'static str {
        match self {
            Channel::Red => "red",
            Channel::Green => "green",
            Channel::Blue => "blue",
        }
    }

    /// Upper-case initial: "R", "G", "B".
    pub const fn letter(self) -> &'static str {
        match self {
            Channel::Red => "R",
            Channel::Green => "G",
            Channel::Blue => "B",
        }
    }
}

impl fmt::Display for Channel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Channel {
    type Err = CoreError;
    fn from_str(s: &str) -> Result<Self, CoreError> {
        match s.trim().to_ascii_lowercase().as_str() {
            "red" | "r" => Ok(Channel::Red),
            "green" | "g" => Ok(Channel::Green),
            "blue" | "b" => Ok(Channel::Blue),
            _ => Err(CoreError::ChannelName(s.to_string())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_name_and_parse_agree_for_every_channel() {
        for (i, c) in Channel::ALL.into_iter().enumerate() {
            assert_eq!(c.index(), i);
            assert_eq!(Channel::from_index(i), Ok(c));
            assert_eq!(c.name().parse::<Channel>(), Ok(c));
            assert_eq!(c.letter().parse::<Channel>(), Ok(c));
        }
        assert_eq!(Channel::from_index(3), Err(CoreError::ChannelIndex(3)));
        assert!("cyan".parse::<Channel>().is_err());
    }
}
