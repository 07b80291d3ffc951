//! SQLite profile store (issue: see README). Filled in by the store work.
