//! Conversions every vocabulary type writes the same way.

/// `From` both ways between a type and its plain array form (`from_array`/`to_array`).
macro_rules! array_conversions {
    ($ty:ty, $array:ty) => {
        impl From<$array> for $ty {
            fn from(a: $array) -> Self {
                Self::from_array(a)
            }
        }

        impl From<$ty> for $array {
            fn from(v: $ty) -> Self {
                v.to_array()
            }
        }
    };
}

/// `TryFrom` the plain number through the validating `new`, and `From` back, for a
/// newtype over one number (what serde's `try_from`/`into` use).
macro_rules! validated_number {
    ($ty:ident, $number:ty) => {
        impl TryFrom<$number> for $ty {
            type Error = $crate::CoreError;
            fn try_from(value: $number) -> Result<Self, $crate::CoreError> {
                Self::new(value)
            }
        }

        impl From<$ty> for $number {
            fn from(v: $ty) -> $number {
                v.0
            }
        }
    };
}

pub(crate) use {array_conversions, validated_number};
