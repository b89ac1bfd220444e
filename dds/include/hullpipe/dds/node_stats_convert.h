// NodeStats (idl/hullpipe.idl) from and to a node's report
// (pipeline/node_counters.h), with validation of what arrives: part of the
// Cyclone wrapper library (hullpipe_dds_base), since every node and tool that
// reports or reads NodeStats needs it and none of them needs an algorithm for it.
#pragma once

#include <cstdint>

#include "hullpipe.h"  // idlc-generated
#include "hullpipe/dds/owned_sample.h"
#include "hullpipe/pipeline/node_stats.h"

namespace hullpipe::dds {

/// NodeStats of a node's report.
OwnedSample<hullpipe_msg_NodeStats> MakeNodeStatsMessage(const NodeStatsSample& s, int64_t stamp_ns);
/// The report in a NodeStats sample (a missing stage name becomes "?"). Throws
/// MessageError for an empty node name, a name or stage name over 64 bytes, a
/// backend over 512, any of them not valid UTF-8 (or with NUL), or over 64 stages.
NodeStatsSample NodeStatsFromMsg(const hullpipe_msg_NodeStats& msg);

}  // namespace hullpipe::dds
