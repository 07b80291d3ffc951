//! Serial colorimeter drivers and their pty emulators.
