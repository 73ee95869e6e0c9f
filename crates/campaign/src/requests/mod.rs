//! What the front ends call, each end to end: a campaign, a shard or a merge of shards, one
//! simulated trial as measurement files ([`campaign`]), a sweep ([`sweep`]), a campaign in
//! memory for bindings ([`in_memory`]) and the identifiability checks ([`check`]).

pub(crate) mod campaign;
pub(crate) mod cartesian;
pub(crate) mod check;
pub(crate) mod in_memory;
pub(crate) mod sweep;
