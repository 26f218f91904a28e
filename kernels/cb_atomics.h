/* cb_atomics.h - kernel-only helpers for race-free accumulation (MLT splats). */
#ifndef CB_ATOMICS_H
#define CB_ATOMICS_H

#include "cb_common.h"

#ifdef CB_KERNEL_SIDE
/* OpenCL 1.2 has no float atomics: compare-and-swap on the bits until no other work-item wrote
 * in between. */
static void atomicAddFloat(volatile __global float* address, float value) {
    volatile __global uint* bits = (volatile __global uint*)address;
    uint expected = *bits;
    for (;;) {
        uint desired = as_uint(as_float(expected) + value);
        uint seen = atomic_cmpxchg(bits, expected, desired);
        if (seen == expected) break;
        expected = seen;
    }
}
#endif

#endif /* CB_ATOMICS_H */
