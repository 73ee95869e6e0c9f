//! Many trials of one campaign: run in parallel and folded into an exact, mergeable
//! aggregate ([`range`]: `run_range`, `Aggregate`; [`aggregate`]: the statistics it is made
//! of), in checkpointed chunks that resume to the same bytes ([`checkpoint`]), in shards run
//! apart and merged ([`shard`]), and again with error sources switched off for the residual
//! budget ([`budget`]).

pub(crate) mod aggregate;
pub(crate) mod budget;
pub(crate) mod checkpoint;
pub(crate) mod range;
pub(crate) mod shard;
