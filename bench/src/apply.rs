//! `lumiwall bench apply`: post-pass throughput against a memory copy, and banding.
