//! Exports other tools read: the measurements of a display as an ArgyllCMS `.ti3`
//! (`colprof`, `profcheck`, DisplayCAL).

pub mod ti3;
