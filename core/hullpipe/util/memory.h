// The allocator's policy for processes that run a loop per frameset
// (docs/benchmarks.md, "Page faults per frameset").
#pragma once

namespace hullpipe {

/// Keeps the memory the process frees for its next frameset instead of giving
/// it back to the kernel. glibc's malloc returns a freed block larger than its
/// mmap threshold (128 KiB, rising with the blocks it has freed) and a heap
/// whose free top passes its trim threshold; the next frameset's allocations of
/// the same size then fault fresh pages in, one fault per 4 KiB. Measured on a
/// shared 2-core VM: 1,000-1,500 faults of about 12 us each, 12-18 ms, in
/// every 20-camera 1024x768 hull box query (VolumeQuery) of a loop that also
/// sweeps, and with this set none after the first query of a size.
///
/// Sets M_MMAP_THRESHOLD to 32 MiB (its largest: blocks below it come from the
/// heap, and it no longer adapts) and M_TRIM_THRESHOLD to 1 GiB (a heap keeps
/// up to that much free memory). A process's resident memory then stays near
/// its peak use, which its bounds on input already bound; its peak does not
/// grow. StartNode (dds/node.h) calls it for every process on the domain, the
/// tools that loop over frames (vh_eval, hullpipe_rig) call it, and the
/// benchmarks call it so that they measure what the nodes pay. Idempotent;
/// does nothing where the C library is not glibc or where a sanitizer's
/// allocator replaces malloc.
void KeepFreedMemory();

}  // namespace hullpipe
