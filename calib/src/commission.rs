//! commission (being written).
