/* host/spirv.c - a kernel's SPIR-V with the calls its specialization constants make
 * unreachable left out, made before a pipeline variant is compiled.
 *
 * Why: picvr's kernels are one module each, with every optional feature behind a
 * specialization constant (shaders/specialization.glsl).  A driver front end such as
 * Mesa's (spirv_to_nir, then inlining every call) translates and inlines the code of a
 * branch the constants rule out before it folds the branch away, and inlining is most
 * of a large kernel's compile.  So each call that sits in a block no path from its
 * function's entry reaches, once the constants are known, becomes OpUndef (a call of a
 * void function is dropped): a function no reachable call names is then never translated.
 *
 * What stays exactly as it was: every block, every branch and merge instruction, every
 * other instruction, every id (the module's bound included), the specialization
 * constants themselves (the driver still applies pSpecializationInfo).  Only code that
 * cannot execute changes, so the compiled kernel computes what the whole one does.
 *
 * Constants: OpConstant/True/False/Null of bool and 32-bit integer type, the spec
 * constants with the values of `spec` (else their defaults), OpSpecConstantOp and the
 * same operations inside functions (logical, integer comparison, select, add, subtract,
 * multiply, bitwise, shifts below 32, copy), and an OpPhi whose incoming values from the
 * blocks still reachable agree.  Anything else is unknown, and a branch on an unknown
 * value keeps both ways: the rule errs toward keeping code.
 *
 * Degenerate input: a module that does not parse (magic, word counts, ids beyond the
 * bound, a block outside a function) gets no pruning: the caller hands the driver the
 * original.  Nothing here trusts a word count or an id before checking it. */

#define PICVR_SPV_MAGIC 0x07230203u
#define PICVR_SPV_MAX_BOUND (1u << 22)     /* ids; picvr's kernels have tens of thousands */
#define PICVR_SPV_FIXPOINT_ROUNDS 8        /* phi evaluation and reachability, alternated */

enum {
    PICVR_OP_UNDEF = 1, PICVR_OP_TYPE_VOID = 19, PICVR_OP_TYPE_BOOL = 20,
    PICVR_OP_TYPE_INT = 21, PICVR_OP_CONSTANT_TRUE = 41, PICVR_OP_CONSTANT_FALSE = 42, PICVR_OP_CONSTANT = 43,
    PICVR_OP_CONSTANT_NULL = 46, PICVR_OP_SPEC_CONSTANT_TRUE = 48, PICVR_OP_SPEC_CONSTANT_FALSE = 49,
    PICVR_OP_SPEC_CONSTANT = 50, PICVR_OP_SPEC_CONSTANT_OP = 52, PICVR_OP_FUNCTION = 54,
    PICVR_OP_FUNCTION_END = 56, PICVR_OP_FUNCTION_CALL = 57, PICVR_OP_DECORATE = 71, PICVR_OP_COPY_OBJECT = 83,
    PICVR_OP_IADD = 128, PICVR_OP_ISUB = 130, PICVR_OP_IMUL = 132, PICVR_OP_LOGICAL_EQUAL = 164,
    PICVR_OP_LOGICAL_NOT_EQUAL = 165, PICVR_OP_LOGICAL_OR = 166, PICVR_OP_LOGICAL_AND = 167,
    PICVR_OP_LOGICAL_NOT = 168, PICVR_OP_SELECT = 169, PICVR_OP_IEQUAL = 170, PICVR_OP_INOT_EQUAL = 171,
    PICVR_OP_UGREATER = 172, PICVR_OP_SGREATER = 173, PICVR_OP_UGREATER_EQUAL = 174,
    PICVR_OP_SGREATER_EQUAL = 175, PICVR_OP_ULESS = 176, PICVR_OP_SLESS = 177, PICVR_OP_ULESS_EQUAL = 178,
    PICVR_OP_SLESS_EQUAL = 179, PICVR_OP_SHIFT_RIGHT_LOGICAL = 194, PICVR_OP_SHIFT_RIGHT_ARITHMETIC = 195,
    PICVR_OP_SHIFT_LEFT_LOGICAL = 196, PICVR_OP_BITWISE_OR = 197, PICVR_OP_BITWISE_XOR = 198,
    PICVR_OP_BITWISE_AND = 199, PICVR_OP_NOT = 200, PICVR_OP_PHI = 245, PICVR_OP_LABEL = 248,
    PICVR_OP_BRANCH = 249, PICVR_OP_BRANCH_CONDITIONAL = 250, PICVR_OP_SWITCH = 251, PICVR_OP_KILL = 252,
    PICVR_OP_RETURN = 253, PICVR_OP_RETURN_VALUE = 254, PICVR_OP_UNREACHABLE = 255,
    PICVR_OP_TERMINATE_INVOCATION = 4416
};
#define PICVR_DECORATION_SPEC_ID 1u

/* A block of a function: its label, the words [begin, end) from OpLabel through its
   terminator, and the terminator's first word. */
typedef struct picvr_spv_block {
    uint32_t label, begin, end, term;
} picvr_spv_block;

/* The scratch of one pruning, all of it indexed by id (bound entries) or by block. */
typedef struct picvr_spv {
    const uint32_t *w;
    size_t words;
    uint32_t bound, void_type;
    uint32_t *spec_id;       /* id: its SpecId decoration, or UINT32_MAX */
    uint8_t *known;          /* id: its value is known */
    uint8_t *kind;           /* id of a type: 1 bool, 2 32-bit integer; else 0 */
    uint32_t *value;         /* id: the known value (bool: 0 or 1) */
    int32_t *block_of;       /* label id: index into blocks, -1 if none */
    picvr_spv_block *blocks;
    uint32_t nblocks;
    uint8_t *live;           /* block: reachable from its function's entry */
    uint32_t *stack;         /* blocks to visit */
} picvr_spv;

static int picvr_spv_id_ok(const picvr_spv *m, uint32_t id) { return id != 0 && id < m->bound; }

static int picvr_spv_known(const picvr_spv *m, uint32_t id, uint32_t *v) {
    if (!picvr_spv_id_ok(m, id) || !m->known[id]) return 0;
    *v = m->value[id];
    return 1;
}

/* The value of operation `op` on known operands a[0..n), of result type `type`; 0 where
   the operation is not one this file evaluates, an operand is unknown, or the result is
   not a bool or 32-bit integer (then *out is untouched). */
static int picvr_spv_eval(const picvr_spv *m, uint32_t op, uint32_t type, const uint32_t *a, uint32_t n,
                          uint32_t *out) {
    if (!picvr_spv_id_ok(m, type) || !m->kind[type] || n == 0 || n > 3) return 0;
    uint32_t x[3];
    for (uint32_t i = 0; i < n; i++)
        if (!picvr_spv_known(m, a[i], &x[i])) return 0;
    uint32_t r;
    switch (op) {
    case PICVR_OP_COPY_OBJECT: if (n != 1) return 0; r = x[0]; break;
    case PICVR_OP_LOGICAL_NOT: if (n != 1) return 0; r = !x[0]; break;
    case PICVR_OP_NOT: if (n != 1) return 0; r = ~x[0]; break;
    case PICVR_OP_SELECT: if (n != 3) return 0; r = x[0] ? x[1] : x[2]; break;
    default:
        if (n != 2) return 0;
        switch (op) {
        case PICVR_OP_LOGICAL_EQUAL: r = (x[0] != 0) == (x[1] != 0); break;
        case PICVR_OP_LOGICAL_NOT_EQUAL: r = (x[0] != 0) != (x[1] != 0); break;
        case PICVR_OP_LOGICAL_OR: r = x[0] || x[1]; break;
        case PICVR_OP_LOGICAL_AND: r = x[0] && x[1]; break;
        case PICVR_OP_IEQUAL: r = x[0] == x[1]; break;
        case PICVR_OP_INOT_EQUAL: r = x[0] != x[1]; break;
        case PICVR_OP_UGREATER: r = x[0] > x[1]; break;
        case PICVR_OP_UGREATER_EQUAL: r = x[0] >= x[1]; break;
        case PICVR_OP_ULESS: r = x[0] < x[1]; break;
        case PICVR_OP_ULESS_EQUAL: r = x[0] <= x[1]; break;
        case PICVR_OP_SGREATER: r = (int32_t)x[0] > (int32_t)x[1]; break;
        case PICVR_OP_SGREATER_EQUAL: r = (int32_t)x[0] >= (int32_t)x[1]; break;
        case PICVR_OP_SLESS: r = (int32_t)x[0] < (int32_t)x[1]; break;
        case PICVR_OP_SLESS_EQUAL: r = (int32_t)x[0] <= (int32_t)x[1]; break;
        case PICVR_OP_IADD: r = x[0] + x[1]; break;     /* 32-bit wrap, as SPIR-V defines */
        case PICVR_OP_ISUB: r = x[0] - x[1]; break;
        case PICVR_OP_IMUL: r = x[0] * x[1]; break;
        case PICVR_OP_BITWISE_OR: r = x[0] | x[1]; break;
        case PICVR_OP_BITWISE_XOR: r = x[0] ^ x[1]; break;
        case PICVR_OP_BITWISE_AND: r = x[0] & x[1]; break;
        /* a shift by 32 or more is undefined in SPIR-V: unknown */
        case PICVR_OP_SHIFT_LEFT_LOGICAL: if (x[1] >= 32) return 0; r = x[0] << x[1]; break;
        case PICVR_OP_SHIFT_RIGHT_LOGICAL: if (x[1] >= 32) return 0; r = x[0] >> x[1]; break;
        case PICVR_OP_SHIFT_RIGHT_ARITHMETIC:
            if (x[1] >= 32) return 0;
            r = (x[0] >> x[1]) | ((x[0] & 0x80000000u) && x[1] ? ~(0xffffffffu >> x[1]) : 0u);
            break;
        default: return 0;
        }
    }
    *out = m->kind[type] == 1 ? (r != 0) : r;
    return 1;
}

static void picvr_spv_set(picvr_spv *m, uint32_t id, uint32_t v) {
    if (!picvr_spv_id_ok(m, id)) return;
    m->known[id] = 1;
    m->value[id] = v;
}

/* The value `spec` gives the constant of SpecId `spec_id`: 1 and *v, or 0 where it gives
   none.  Entries of 1 to 4 bytes are read as the low bytes of a 32-bit value (a VkBool32
   is nonzero for true); an entry beyond pData's size is ignored. */
static int picvr_spv_spec_value(const VkSpecializationInfo *spec, uint32_t spec_id, uint32_t *v) {
    if (!spec || !spec->pMapEntries || !spec->pData) return 0;
    for (uint32_t i = 0; i < spec->mapEntryCount; i++) {
        const VkSpecializationMapEntry *e = &spec->pMapEntries[i];
        if (e->constantID != spec_id) continue;
        if (e->size == 0 || e->size > 4 || e->offset > spec->dataSize || e->size > spec->dataSize - e->offset) return 0;
        uint32_t x = 0;
        const uint8_t *p = (const uint8_t *)spec->pData + e->offset;
        for (size_t b = 0; b < e->size; b++) x |= (uint32_t)p[b] << (8 * b);
        *v = x;
        return 1;
    }
    return 0;
}

/* The module's constants of the global section, with the spec constants' values.
   0: the module does not parse. */
static int picvr_spv_globals(picvr_spv *m, const VkSpecializationInfo *spec) {
    const uint32_t *w = m->w;
    size_t functions = m->words;       /* where the global section ends */
    for (size_t i = 5; i < m->words;) {   /* SpecIds first: decorations precede what they decorate */
        uint32_t n = w[i] >> 16, op = w[i] & 0xffffu;
        if (n == 0 || n > m->words - i) return 0;
        if (op == PICVR_OP_FUNCTION) { functions = i; break; }
        if (op == PICVR_OP_DECORATE && n >= 4 && w[i + 2] == PICVR_DECORATION_SPEC_ID && picvr_spv_id_ok(m, w[i + 1]))
            m->spec_id[w[i + 1]] = w[i + 3];
        i += n;
    }
    for (size_t i = 5; i < functions;) {
        uint32_t n = w[i] >> 16, op = w[i] & 0xffffu;
        if (op == PICVR_OP_TYPE_VOID && n >= 2) m->void_type = w[i + 1];
        if (op == PICVR_OP_TYPE_BOOL && n >= 2 && picvr_spv_id_ok(m, w[i + 1])) m->kind[w[i + 1]] = 1;
        if (op == PICVR_OP_TYPE_INT && n >= 4 && picvr_spv_id_ok(m, w[i + 1]) && w[i + 2] == 32) m->kind[w[i + 1]] = 2;
        if (n >= 3 && picvr_spv_id_ok(m, w[i + 1]) && m->kind[w[i + 1]] && picvr_spv_id_ok(m, w[i + 2])) {
            uint32_t type = w[i + 1], id = w[i + 2], v = 0;
            int have = 1;
            if ((op == PICVR_OP_SPEC_CONSTANT_TRUE || op == PICVR_OP_SPEC_CONSTANT_FALSE || op == PICVR_OP_SPEC_CONSTANT) &&
                m->spec_id[id] != UINT32_MAX && picvr_spv_spec_value(spec, m->spec_id[id], &v))
                v = m->kind[type] == 1 ? (v != 0) : v;
            else if (op == PICVR_OP_CONSTANT_TRUE || op == PICVR_OP_SPEC_CONSTANT_TRUE) v = 1;
            else if (op == PICVR_OP_CONSTANT_FALSE || op == PICVR_OP_SPEC_CONSTANT_FALSE) v = 0;
            else if (op == PICVR_OP_CONSTANT_NULL) v = 0;
            else if ((op == PICVR_OP_CONSTANT || op == PICVR_OP_SPEC_CONSTANT) && n == 4) v = w[i + 3];
            else if (op == PICVR_OP_SPEC_CONSTANT_OP && n >= 5) have = picvr_spv_eval(m, w[i + 3], type, w + i + 4, n - 4, &v);
            else have = 0;
            if (have) picvr_spv_set(m, id, v);
        }
        i += n;
    }
    return 1;
}

/* Blocks of the function whose words are [begin, end): 0 if they do not parse. */
static int picvr_spv_blocks(picvr_spv *m, size_t begin, size_t end) {
    const uint32_t *w = m->w;
    m->nblocks = 0;
    int open = 0;
    for (size_t i = begin; i < end;) {
        uint32_t n = w[i] >> 16, op = w[i] & 0xffffu;
        if (op == PICVR_OP_LABEL) {
            if (open || n < 2 || !picvr_spv_id_ok(m, w[i + 1])) return 0;
            picvr_spv_block *b = &m->blocks[m->nblocks];
            b->label = w[i + 1];
            b->begin = (uint32_t)i;
            m->block_of[b->label] = (int32_t)m->nblocks++;
            open = 1;
        } else if (op == PICVR_OP_BRANCH || op == PICVR_OP_BRANCH_CONDITIONAL || op == PICVR_OP_SWITCH ||
                   op == PICVR_OP_KILL || op == PICVR_OP_RETURN || op == PICVR_OP_RETURN_VALUE ||
                   op == PICVR_OP_UNREACHABLE || op == PICVR_OP_TERMINATE_INVOCATION) {
            if (!open) return 0;
            m->blocks[m->nblocks - 1].end = (uint32_t)(i + n);
            m->blocks[m->nblocks - 1].term = (uint32_t)i;
            open = 0;
        }
        i += n;
    }
    return !open;
}

/* The block labelled `label` reached (a label of no block of this function: nothing):
   marked, and queued if it was not yet. */
static void picvr_spv_visit(picvr_spv *m, uint32_t label, uint32_t *top) {
    int32_t c = picvr_spv_id_ok(m, label) ? m->block_of[label] : -1;
    if (c >= 0 && !m->live[c]) {
        m->live[c] = 1;
        m->stack[(*top)++] = (uint32_t)c;
    }
}

/* Marks the blocks reachable from the function's first block, following a conditional
   branch or a switch only where a known value takes it.  A switch on an unknown
   selector reaches every block any of its words names (its literals' width is the
   selector's, which this file does not track: a literal that happens to equal a label
   only keeps more code). */
static void picvr_spv_reach(picvr_spv *m) {
    const uint32_t *w = m->w;
    memset(m->live, 0, m->nblocks);
    if (m->nblocks == 0) return;
    uint32_t top = 0;
    m->live[0] = 1;
    m->stack[top++] = 0;
    while (top) {
        const picvr_spv_block *b = &m->blocks[m->stack[--top]];
        size_t i = b->term;
        uint32_t n = w[i] >> 16, op = w[i] & 0xffffu, v;
        if (op == PICVR_OP_BRANCH && n >= 2) picvr_spv_visit(m, w[i + 1], &top);
        else if (op == PICVR_OP_BRANCH_CONDITIONAL && n >= 4) {
            if (picvr_spv_known(m, w[i + 1], &v)) picvr_spv_visit(m, v ? w[i + 2] : w[i + 3], &top);
            else {
                picvr_spv_visit(m, w[i + 2], &top);
                picvr_spv_visit(m, w[i + 3], &top);
            }
        } else if (op == PICVR_OP_SWITCH && n >= 3) {
            if (picvr_spv_known(m, w[i + 1], &v)) {   /* known: a 32-bit selector, one-word literals */
                uint32_t chosen = w[i + 2];
                for (uint32_t k = 3; k + 1 < n; k += 2)
                    if (w[i + k] == v) { chosen = w[i + k + 1]; break; }
                picvr_spv_visit(m, chosen, &top);
            } else {
                for (uint32_t k = 2; k < n; k++) picvr_spv_visit(m, w[i + k], &top);
            }
        }
    }
}

/* The known values of the function's instructions, in order (a definition precedes its
   uses in SPIR-V's block order, except through OpPhi), with phis taken from the
   incoming blocks that are live.  Returns the number of ids newly known. */
static uint32_t picvr_spv_eval_function(picvr_spv *m) {
    const uint32_t *w = m->w;
    uint32_t found = 0;
    for (uint32_t b = 0; b < m->nblocks; b++) {
        if (!m->live[b]) continue;
        for (size_t i = m->blocks[b].begin; i < m->blocks[b].end;) {
            uint32_t n = w[i] >> 16, op = w[i] & 0xffffu, v = 0;
            if (n >= 3 && picvr_spv_id_ok(m, w[i + 2]) && !m->known[w[i + 2]] && picvr_spv_id_ok(m, w[i + 1]) &&
                m->kind[w[i + 1]]) {
                int have = 0;
                if (op == PICVR_OP_PHI) {
                    uint32_t live_in = 0, agree = 1, first = 0, x;
                    for (uint32_t k = 3; k + 1 < n; k += 2) {
                        int32_t c = picvr_spv_id_ok(m, w[i + k + 1]) ? m->block_of[w[i + k + 1]] : -1;
                        if (c < 0 || !m->live[c]) continue;
                        if (!picvr_spv_known(m, w[i + k], &x)) { agree = 0; break; }
                        if (live_in++ == 0) first = x;
                        else if (x != first) agree = 0;
                    }
                    have = agree && live_in > 0;
                    v = first;
                } else {
                    have = picvr_spv_eval(m, op, w[i + 1], w + i + 3, n - 3, &v);
                }
                if (have) { picvr_spv_set(m, w[i + 2], v); found++; }
            }
            i += n;
        }
    }
    return found;
}

/* Writes the pruned copy of function [begin, end) to out (at *o): a call in a block
   that is not live becomes OpUndef of its type, or nothing where the function returns
   void.  Returns the calls taken out. */
static uint32_t picvr_spv_copy_function(const picvr_spv *m, size_t begin, size_t end, uint32_t *out, size_t *o) {
    const uint32_t *w = m->w;
    uint32_t pruned = 0, b = 0;
    int live = 1;
    for (size_t i = begin; i < end;) {
        uint32_t n = w[i] >> 16, op = w[i] & 0xffffu;
        if (op == PICVR_OP_LABEL) live = m->live[b++];
        if (op == PICVR_OP_FUNCTION_CALL && !live && n >= 4) {
            pruned++;
            if (w[i + 1] != m->void_type) {
                out[(*o)++] = (3u << 16) | PICVR_OP_UNDEF;
                out[(*o)++] = w[i + 1];
                out[(*o)++] = w[i + 2];
            }
        } else {
            memcpy(out + *o, w + i, n * sizeof(uint32_t));
            *o += n;
        }
        i += n;
    }
    return pruned;
}

/* The pruned module of `code` (words 32-bit words) under `spec`, in *out (words in
   *out_words), allocated with `alloc`; the caller frees it.  Returns the calls taken
   out, or -1 where the module does not parse or memory ran out (*out NULL: use the
   original). */
static long picvr_spirv_prune(const picvr_allocator *alloc, const uint32_t *code, size_t words,
                              const VkSpecializationInfo *spec, uint32_t **out, size_t *out_words) {
    *out = NULL;
    *out_words = 0;
    if (!code || words < 5 || code[0] != PICVR_SPV_MAGIC || code[3] == 0 || code[3] > PICVR_SPV_MAX_BOUND) return -1;
    picvr_spv m;
    memset(&m, 0, sizeof m);
    m.w = code;
    m.words = words;
    m.bound = code[3];
    size_t max_blocks = words / 2 + 1;   /* a block takes at least OpLabel and a terminator */
    m.spec_id = (uint32_t *)picvr_host_alloc(alloc, (size_t)m.bound * sizeof(uint32_t));
    m.known = (uint8_t *)picvr_host_alloc(alloc, m.bound);
    m.kind = (uint8_t *)picvr_host_alloc(alloc, m.bound);
    m.value = (uint32_t *)picvr_host_alloc(alloc, (size_t)m.bound * sizeof(uint32_t));
    m.block_of = (int32_t *)picvr_host_alloc(alloc, (size_t)m.bound * sizeof(int32_t));
    m.blocks = (picvr_spv_block *)picvr_host_alloc(alloc, max_blocks * sizeof(picvr_spv_block));
    m.live = (uint8_t *)picvr_host_alloc(alloc, max_blocks);
    m.stack = (uint32_t *)picvr_host_alloc(alloc, max_blocks * sizeof(uint32_t));
    uint32_t *res = (uint32_t *)picvr_host_alloc(alloc, words * sizeof(uint32_t));
    long pruned = -1;
    if (m.spec_id && m.known && m.kind && m.value && m.block_of && m.blocks && m.live && m.stack && res) {
        memset(m.known, 0, m.bound);
        memset(m.kind, 0, m.bound);
        memset(m.value, 0, (size_t)m.bound * sizeof(uint32_t));
        for (uint32_t id = 0; id < m.bound; id++) {
            m.block_of[id] = -1;
            m.spec_id[id] = UINT32_MAX;
        }
        pruned = picvr_spv_globals(&m, spec) ? 0 : -1;
        size_t o = 0, i = 5;
        if (pruned == 0) {
            memcpy(res, code, 5 * sizeof(uint32_t));
            o = 5;
        }
        while (pruned >= 0 && i < words) {
            uint32_t n = code[i] >> 16, op = code[i] & 0xffffu;
            if (n == 0 || n > words - i) { pruned = -1; break; }
            if (op != PICVR_OP_FUNCTION) {
                if (op == PICVR_OP_LABEL) { pruned = -1; break; }   /* a block outside a function */
                memcpy(res + o, code + i, n * sizeof(uint32_t));
                o += n;
                i += n;
                continue;
            }
            size_t end = i;
            while (end < words && (code[end] & 0xffffu) != PICVR_OP_FUNCTION_END) {
                uint32_t k = code[end] >> 16;
                if (k == 0 || k > words - end) break;
                end += k;
            }
            if (end >= words || (code[end] >> 16) == 0 || (code[end] >> 16) > words - end) { pruned = -1; break; }
            end += code[end] >> 16;             /* through OpFunctionEnd */
            if (!picvr_spv_blocks(&m, i, end)) { pruned = -1; break; }
            picvr_spv_reach(&m);
            for (int r = 0; r < PICVR_SPV_FIXPOINT_ROUNDS && picvr_spv_eval_function(&m); r++) picvr_spv_reach(&m);
            pruned += picvr_spv_copy_function(&m, i, end, res, &o);
            for (uint32_t b = 0; b < m.nblocks; b++) m.block_of[m.blocks[b].label] = -1;
            i = end;
        }
        if (pruned >= 0) {
            *out = res;
            *out_words = o;
            res = NULL;
        }
    }
    picvr_host_free(alloc, res);
    picvr_host_free(alloc, m.stack);
    picvr_host_free(alloc, m.live);
    picvr_host_free(alloc, m.blocks);
    picvr_host_free(alloc, m.block_of);
    picvr_host_free(alloc, m.value);
    picvr_host_free(alloc, m.kind);
    picvr_host_free(alloc, m.known);
    picvr_host_free(alloc, m.spec_id);
    return pruned;
}
