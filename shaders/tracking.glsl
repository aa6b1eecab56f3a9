// tracking.glsl - delta (Woodcock) tracking and (residual) ratio tracking through the
// majorant grids (paper Eq. 1-3): free-flight sampling of scatter events and the
// transmittance estimate of shadow rays, in one walk for both, with the loop bounds of
// limits.glsl and, with bounces, the path's shared loop pool.
#ifndef TRACKING_GLSL_ONCE
#define TRACKING_GLSL_ONCE 1
#include "specialization.glsl"
#include "limits.glsl"
#include "scene.glsl"
#include "random.glsl"
#include "medium.glsl"
#include "majorant.glsl"

// One ratio-tracking collision with extinction s under majorant m: T *= 1 - s / m (Eq.
// 2), and Russian roulette below 0.1, which ends long, dark paths early without bias
// (a survivor is raised to 0.1).  Returns true when the path ended (T = 0).
bool ratio_collide(inout float T, float s, float m, inout Rng rng) {
    // s <= m by construction; the clamp keeps T >= 0 under rounding
    T *= clamp(1.0 - s / m, 0.0, 1.0);
    if (T < 0.1) {
        if (T <= 0.0 || rnd(rng) >= T * 10.0) { T = 0.0; return true; }
        T = 0.1;
    }
    return false;
}

// The control extinction of residual ratio tracking in coarse cell d: the cell's
// minorant (the third part of the majorant buffer; 0 where the transfer function
// reaches 0 over the cell's value range), so sigma_t - control lies in [0, majorant -
// control] everywhere in the cell.
float cell_minorant(Dda d) {
    uint cells = scene.grid.x * scene.grid.y * scene.grid.z;
    return majorant[2u * cells + cell_index(d)];
}

// The control c of cell d whose majorant is maj: its minorant with USE_RESIDUAL (at most
// maj; 0 in empty cells), else 0.
float cell_control(Dda d, float maj) { return USE_RESIDUAL && maj > 0.0 ? min(cell_minorant(d), maj) : 0.0; }

// One tentative collision at t under majorant m and control c (the minorant with
// USE_RESIDUAL, else 0).  Delta tracking: real with probability sigma_t / m (returns
// true); below the control c <= sigma_t that holds without looking sigma_t up.  Ratio
// tracking: T takes the weight 1 - (sigma_t - c) / (m - c) (residual ratio tracking,
// Novak et al. 2014, "Residual ratio tracking for estimating attenuation in participating
// media", §5: the control's part exp(-c l) is applied exactly by the caller along the
// way, the residual part is ratio-tracked, so E[T] = exp(-tau)); returns true when T
// fell to 0.
bool tentative_collision(bool ratio, vec3 x, float m, float c, float u_qmc, inout float T, inout Rng rng) {
    if (!ratio) {
        float u = (u_qmc >= 0.0 ? u_qmc : rnd(rng)) * m;
        return u < c || u < sigma_t(x);
    }
    return ratio_collide(T, sigma_t(x) - c, m - c, rng);
}

// A free flight in optical depth against the tracking rate: -log(1 - u), drawn when the
// previous one ended (flight.depth < 0) and carried across cell boundaries, so that one
// number decides the whole flight (the memoryless exponential makes carrying the rest
// and drawing afresh per cell the same distribution; carried, a pixel's sequence
// stratifies where its camera rays first collide).  The camera ray's first flight takes
// its number and its tentative collision's test from the pixel's QMC_FLIGHT pair
// (rng.flight); u_test < 0 where the test draws its own.
struct Flight { float depth; float u_test; };

Flight flight_start() { return Flight(-1.0, -1.0); }

// The next tentative collision after t under majorant m and control c: delta tracking
// at rate m, ratio tracking at rate m - c (the residual); t_end when the rate is 0 (the
// flight's depth is then kept whole).  Ratio tracking's T takes the control's
// attenuation up to there.  -log(1 - u) is finite because u < 1 (24 bits).  Rule: the
// depth left after a cell is clamped at 0 (rounding), which ends the flight at the next
// cell's start, a bias below float's resolution.
float next_tentative(bool ratio, float t, float t_end, float m, float c, inout float T, inout Flight fl,
                     inout Rng rng) {
    float rate = ratio ? m - c : m;
    float t_try = t_end;
    if (rate > 0.0) {
        if (fl.depth < 0.0) {
            float u;
            if (USE_QMC && rng.flight) {
                vec2 q = qmc_pair(rng, QMC_FLIGHT);
                u = q.x;
                fl.u_test = q.y;
            } else {
                u = rnd(rng);
                fl.u_test = -1.0;
            }
            rng.flight = false;
            fl.depth = -log(1.0 - u);
        }
        t_try = t + fl.depth / rate;
        fl.depth = t_try < t_end ? -1.0 : max(fl.depth - rate * (t_end - t), 0.0);
    }
    if (ratio && c > 0.0) T *= exp(-c * (min(t_try, t_end) - t));
    return t_try;
}

// With USE_BOUNCES, the loop iterations this invocation's tracking loops may still take
// together (llvmpipe's cap is on their sum, and a path runs two of them per scatter
// event): each loop runs at most min(MAX_TRACK_STEPS, path_pool) and takes what it ran.
uint path_pool = PATH_STEPS;

// Whether the last walk of track() met a coarse cell with medium (majorant > 0) before
// it ended: false only for a segment it crossed that holds no medium at all, where
// nothing scatters and the transmittance is exactly 1 (render_track.glsl).
bool track_met_medium = false;

// Tracking through one dense brick at voxel resolution, from t to t_end, with the
// brick's control c (it bounds sigma_t from below in each voxel too), sharing the
// caller's step counter and its bound.  Returns true when the walk ended the whole track:
// a real collision (delta tracking; t holds it) or a zero transmittance (ratio tracking).
bool fine_segment(bool ratio, vec3 ro, vec3 rd, inout float t, float t_end, float c, inout float T,
                  inout Flight fl, inout Rng rng, inout uint steps, uint limit) {
    Dda f = fine_start(ro, rd, t);
    float m = max(fine_majorant(f), c);
    for (; steps < limit; steps++) {
        float t_seg = min(dda_exit(f), t_end);
        float t_try = next_tentative(ratio, t, t_seg, m, c, T, fl, rng);
        if (t_try < t_seg) {
            t = t_try;
            if (tentative_collision(ratio, ro + rd * t, m, c, fl.u_test, T, rng)) return true;
            fl.u_test = -1.0;
            continue;
        }
        t = t_seg;
        if (t >= t_end || !dda_advance(f)) { t = t_end; return false; }
        m = max(fine_majorant(f), c);
    }
    return false;
}

// Delta (Woodcock) tracking (ratio false) or ratio tracking (ratio true) in [t0, t1]:
// one walk through the majorant grid for both; every caller passes a constant, so each
// compiles to its own loop.  Free flights restart at cell boundaries (the exponential
// distribution is memoryless), so each cell uses its own majorant and, with
// USE_RESIDUAL, its minorant as the control (residual ratio tracking; delta tracking
// saves lookups with it).  One flat loop: every iteration is one tentative collision,
// cell step or empty-space jump (also inside fine_segment), so that SIMD lanes advance
// together, and all count against one bound (MAX_TRACK_STEPS, and the path's pool);
// past it the track is truncated (counted in `truncated`).  Returns, for delta tracking,
// the distance of a real collision or -1 when the ray passes (a cut walk too: its caller
// reads `truncated`); for ratio tracking, the transmittance estimate (Eq. 2).
// Rule: a cut ratio-tracking walk returns 0, not its partial product: the product of the
// steps it did not take is unknown, and a walk cut before its first step (a path whose
// pool is dry) would return 1, light leaking through medium it never crossed.  Biased
// toward dark, counted.
float track(bool ratio, vec3 ro, vec3 rd, float t0, float t1, inout Rng rng, inout bool truncated) {
    Dda d = coarse_start(ro, rd, t0);
    float t = t0, T = 1.0;
    float maj = cell_majorant(d);
    float c = cell_control(d, maj);
    uint limit = USE_BOUNCES ? min(MAX_TRACK_STEPS, path_pool) : MAX_TRACK_STEPS;
    uint i = 0u;
    Flight fl = flight_start();
    bool ended = false;      // a collision (delta) or a zero transmittance (ratio)
    bool passed = false;     // the ray left [t0, t1]
    track_met_medium = false;
    for (; i < limit; i++) {
        float t_cell = min(dda_exit(d), t1);
        if (maj > 0.0) {
            track_met_medium = true;
            if (USE_FINE && (ratio ? maj - c : maj) * (t_cell - t) > FINE_THRESHOLD) {
                if (fine_segment(ratio, ro, rd, t, t_cell, c, T, fl, rng, i, limit)) { ended = true; break; }
                if (i >= limit) break;
            } else {
                float t_try = next_tentative(ratio, t, t_cell, maj, c, T, fl, rng);
                if (t_try < t_cell) {
                    t = t_try;
                    if (tentative_collision(ratio, ro + rd * t, maj, c, fl.u_test, T, rng)) { ended = true; break; }
                    fl.u_test = -1.0;
                    continue;
                }
            }
            // a control alone does not end a path: roulette it as a collision would
            if (ratio && T < 0.1 && ratio_collide(T, 0.0, 1.0, rng)) { ended = true; break; }
        } else {
            float jump = empty_skip(d, rd);
            if (jump > 0.0) {
                t += jump;
                if (t >= t1) { passed = true; break; }
                d = coarse_start(ro, rd, t);
                maj = cell_majorant(d);
                c = cell_control(d, maj);
                continue;
            }
        }
        t = t_cell;
        if (t >= t1 || !dda_advance(d)) { passed = true; break; }
        maj = cell_majorant(d);
        c = cell_control(d, maj);
    }
    if (USE_BOUNCES) path_pool -= min(i + 1u, path_pool);
    if (ended) return ratio ? 0.0 : t;
    if (!passed) truncated = true;
    return ratio ? (passed ? T : 0.0) : -1.0;
}

float delta_track(vec3 ro, vec3 rd, float t0, float t1, inout Rng rng, inout bool truncated) {
    return track(false, ro, rd, t0, t1, rng, truncated);
}

float ratio_track(vec3 ro, vec3 rd, float t0, float t1, inout Rng rng, inout bool truncated) {
    return track(true, ro, rd, t0, t1, rng, truncated);
}

#endif
