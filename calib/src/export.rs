//! Exports other tools read: the measurements of a display as an ArgyllCMS `.ti3`
//! (`colprof`, `profcheck`, DisplayCAL), and a display's profile as a `.cube` 3D LUT
//! (media servers, projectors).

pub mod cube;
pub mod ti3;
