//! `lumiwall bench radiosity`: error against time on the Cornell box, and the scale study.
