//! `lumiwall bench readings`: calibration accuracy against the number of meter readings.
