//! Scalar reference of the post-pass maths (being written).
