//! What a campaign writes: the summary ([`summary`]: `summary.json`, `summary.md`), the
//! report of one trial ([`trial_report`]), the figures and `report.html` ([`plots`]), and the
//! set of files rendered in memory and written all or nothing ([`files`]).

pub(crate) mod files;
pub(crate) mod plots;
pub(crate) mod summary;
pub(crate) mod trial_report;
