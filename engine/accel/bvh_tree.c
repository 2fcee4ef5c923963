// The BVH's nodes: leaves and interior nodes as the splits make them, the subtrees below the top
// (one thread's task each), and the final depth-first order they are assembled in (bvh.c).
#include <stdlib.h>
#include <string.h>

#include "accel/bvh_internal.h"
#include "core/parallel.h"

// Makes node a leaf over the task's primitives; records its depth.
void pn_bvh_make_leaf(builder *b, pn_bvh_node *node, const task *t)
{
    node->first = t->begin;
    node->count = t->end - t->begin;
    uint32_t d = t->depth + 1, old = atomic_load(&b->depth);
    while (d > old && !atomic_compare_exchange_weak(&b->depth, &old, d))
        ;
}

// Makes node (the task's) interior with children over [begin, split) and [split, end), whose
// bounds are side[]: nodes[*count] and the next, which *count then passes; sets their tasks.
void pn_bvh_make_interior(pn_bvh_node *node, const task *t, uint32_t split_at, const aabb side[4], pn_bvh_node *nodes,
                          uint32_t *count, task kids[2])
{
    uint32_t child = *count;
    *count += 2;
    node->first = child;
    node->count = 0;
    for (int i = 0; i < 2; i++) {
        task *k = &kids[i];
        k->node = child + i;
        k->begin = i == 0 ? t->begin : split_at;
        k->end = i == 0 ? split_at : t->end;
        k->depth = t->depth + 1;
        k->box = side[2 * i];
        k->cbox = side[2 * i + 1];
        pn_bvh_node *c = &nodes[k->node];
        memcpy(c->min, k->box.lo, sizeof c->min);
        memcpy(c->max, k->box.hi, sizeof c->max);
    }
}

// Builds the subtree of task t on this thread, then writes its primitives' order to ids. Its
// root is top[t.node]; the descendants are numbered in the order of the final array (pn_bvh_assemble()).
// Returns their count.
static uint32_t build_subtree(builder *b, task t)
{
    prim *p = b->prims[t.in_other];
    uint32_t *id = b->id[t.in_other];
    pn_bvh_node *local = b->sub + 2 * (size_t)t.begin;
    uint32_t count = 0;
    task stack[2 * MAX_DEPTH + 8];
    int sp = 0;
    stack[sp++] = t;
    for (bool root = true; sp > 0; root = false) {
        task cur = stack[--sp];
        pn_bvh_node *node = root ? &b->top[cur.node] : &local[cur.node];
        aabb side[4];
        uint32_t split_at = cur.depth + 1 >= MAX_DEPTH ? cur.begin : pn_bvh_split_node(p, id, &cur, side);
        if (split_at == cur.begin) { // leaf (also when the depth limit is reached)
            pn_bvh_make_leaf(b, node, &cur);
            continue;
        }
        task kids[2];
        pn_bvh_make_interior(node, &cur, split_at, side, local, &count, kids);
        stack[sp++] = kids[1]; // the left child is taken first
        stack[sp++] = kids[0];
    }
    if (t.in_other)
        memcpy(b->id[0] + t.begin, id + t.begin, (size_t)(t.end - t.begin) * sizeof *id);
    return count;
}

void pn_bvh_build_tasks(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    par_ctx *p = ctx;
    for (uint64_t i = begin; i < end; i++)
        p->count[i] = build_subtree(p->b, p->tasks[i]);
}

static void place_tasks(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    par_ctx *p = ctx;
    for (uint64_t i = begin; i < end; i++) {
        const pn_bvh_node *local = p->b->sub + 2 * (size_t)p->tasks[i].begin;
        pn_bvh_node *dst = p->nodes + p->at[i];
        for (uint32_t j = 0; j < p->count[i]; j++) {
            dst[j] = local[j];
            if (dst[j].count == 0)
                dst[j].first += p->at[i];
        }
    }
}

// Puts the nodes in their final order: depth first, left child first, each interior node's two
// children placed together when it is visited. That order follows from the tree alone: the same
// on any number of threads (issue 30). Walks the top nodes; the descendants of a task's root are
// one run of that order (all of a node's descendants come right after its children's pair is
// placed, before anything outside it), which the task numbered in that order already: they are
// copied over, by all threads. Returns the array, or NULL when out of memory.
pn_bvh_node *pn_bvh_assemble(par_ctx *p, uint32_t ntasks, uint32_t *node_count)
{
    const builder *b = p->b;
    uint32_t total = b->top_count;
    for (uint32_t i = 0; i < ntasks; i++)
        total += p->count[i];
    uint32_t *task_of = malloc((size_t)b->top_count * sizeof *task_of);
    pn_bvh_node *dst = malloc((size_t)total * sizeof *dst);
    if (!task_of || !dst) {
        free(task_of), free(dst);
        return NULL;
    }
    for (uint32_t i = 0; i < b->top_count; i++)
        task_of[i] = UINT32_MAX;
    for (uint32_t i = 0; i < ntasks; i++)
        task_of[p->tasks[i].node] = i;
    // (top node, its place) of nodes placed but whose children are not: at most one pending right
    // sibling per level, and leaves are never deeper than MAX_DEPTH.
    uint32_t stack[MAX_DEPTH + 8][2];
    int sp = 0;
    uint32_t next = 1;
    dst[0] = b->top[0];
    stack[sp][0] = 0, stack[sp][1] = 0, sp++;
    while (sp > 0) {
        sp--;
        uint32_t s = stack[sp][0], d = stack[sp][1], t = task_of[s];
        if (b->top[s].count > 0) // a leaf (or the root of no primitives)
            continue;
        if (t != UINT32_MAX) { // a task's root: its descendants' run
            if (p->count[t] > 0)
                dst[d].first = next;
            p->at[t] = next;
            next += p->count[t];
            continue;
        }
        uint32_t c = next, sc = b->top[s].first;
        next += 2;
        dst[c] = b->top[sc];
        dst[c + 1] = b->top[sc + 1];
        dst[d].first = c;
        stack[sp][0] = sc + 1, stack[sp][1] = c + 1, sp++; // right below left: left is visited first
        stack[sp][0] = sc, stack[sp][1] = c, sp++;
    }
    free(task_of);
    p->nodes = dst;
    pn_parallel_for(ntasks, 1, place_tasks, p);
    *node_count = total;
    return dst;
}
