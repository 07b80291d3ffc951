//! Typed calibration errors: every failure of measuring, fitting or solving names the
//! display or channel concerned and says what the technician can do about it.

/// Errors of measurement, fitting and solving.
#[derive(Debug, thiserror::Error)]
pub enum CalibError {
    /// A device failed.
    #[error(transparent)]
    Device(#[from] lumiwall_devices::DeviceError),
    /// A profile could not be built or stored.
    #[error(transparent)]
    Profile(#[from] lumiwall_profiles::ProfileError),
    /// A reading or input value is NaN or infinite.
    #[error(
        "{what} is not a finite number ({value}); re-measure it (meter over range or disconnected?)"
    )]
    NonFinite {
        /// Which value (display, channel, drive).
        what: String,
        /// The offending value.
        value: f64,
    },
    /// A reading that must not be negative is negative.
    #[error("{what} is negative ({value}); check the meter's zero calibration and re-measure")]
    Negative {
        /// Which value (display, channel, drive).
        what: String,
        /// The offending value.
        value: f64,
    },
    /// A tone ramp has too few usable samples to fit a curve.
    #[error(
        "{what}: only {got} usable ramp samples, at least {need} needed; measure more drive levels"
    )]
    TooFewSamples {
        /// Which ramp.
        what: String,
        /// Usable samples found.
        got: usize,
        /// Samples needed.
        need: usize,
    },
    /// A channel at full drive is not brighter than black: the curve cannot be normalised.
    #[error(
        "{what}: full drive gives relative intensity {full_drive} (black removed), not above 0; is the channel dead or the meter pointed elsewhere?"
    )]
    NoSignal {
        /// Which ramp or channel.
        what: String,
        /// Intensity measured at full drive.
        full_drive: f64,
    },
    /// A display's primaries are (nearly) collinear in xy: it has no usable gamut.
    #[error(
        "{display}: primaries are degenerate (xy triangle area {area:.2e}, need > {min_area:.0e}); a channel is missing or the meter saw the same colour three times"
    )]
    DegeneratePrimaries {
        /// The display (index or key).
        display: String,
        /// Area of its xy triangle.
        area: f64,
        /// Smallest area accepted.
        min_area: f64,
    },
    /// The displays share no common gamut.
    #[error(
        "the xy gamuts have no common area once {display} is included; check its primaries or leave it out"
    )]
    EmptyGamut {
        /// The display whose triangle emptied the intersection.
        display: String,
    },
    /// A requested correlated colour temperature is outside the supported range.
    #[error(
        "colour temperature {kelvin} K is outside {min_k}..={max_k} K supported by the CIE daylight locus"
    )]
    CctOutOfRange {
        /// Requested temperature in kelvin.
        kelvin: f64,
        /// Lowest supported temperature.
        min_k: f64,
        /// Highest supported temperature.
        max_k: f64,
    },
    /// The requested white cannot be shown on a display (e.g. its black is above it).
    #[error("{display}: {reason}")]
    UnreachableWhite {
        /// The display.
        display: String,
        /// What went wrong, with the numbers.
        reason: String,
    },
    /// A solve option or argument is invalid.
    #[error("invalid {option}: {reason}")]
    InvalidOption {
        /// The option.
        option: String,
        /// Why it is invalid.
        reason: String,
    },
    /// A matrix that must be invertible is singular.
    #[error("{what}: matrix is singular and cannot be inverted")]
    Singular {
        /// Which matrix.
        what: String,
    },
}
