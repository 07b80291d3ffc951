//! Exports other tools read: the measurements of a display as an ArgyllCMS `.ti3`
//! (`colprof`, `profcheck`, DisplayCAL), a display's profile as a `.cube` 3D LUT (media
//! servers, projectors) and its grey axis as ArgyllCMS `.cal` curves (video card tables);
//! the whole wall as a VESA MPCDI v2.0 package (media servers, warp-and-blend engines).

pub mod cal;
pub mod cube;
pub mod mpcdi;
pub mod ti3;
