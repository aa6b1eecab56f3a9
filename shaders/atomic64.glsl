// atomic64.glsl - a 64-bit device counter kept in two uint words (the high word takes
// the low word's carry), for sums that outgrow 32 bits over an image's rounds.

// LO and HI, buffer members, gain w.  A macro, as GLSL passes no buffer member by
// reference.  Exact once the adds are done: each add that wraps the low word gives the
// high word its one carry.
#define ATOMIC_ADD64(LO, HI, w) {                                                  \
    uint w_ = (w);                                                                  \
    uint old_ = atomicAdd(LO, w_);                                                  \
    if (old_ + w_ < old_) atomicAdd(HI, 1u);                                        \
}
