"""Slow, plain-Python versions of the optimiser kernels, written straight from the equations,
for the kernels to be checked against on the same draws. They score paths with the shared
fitness `score_paths` (tested on its own), add the horizon value of each path's last cell in
plain Python, and share nothing else with the kernels."""

from __future__ import annotations

import math

import numpy as np

from planner.reward import score_paths

DEPTH_WEIGHT = 1000.0


class Scorer:
    """Scores choice rows for subgroup g, every other subgroup's current best counting as a soft
    vehicle; returns fitness, J1, depth and cells per row."""

    def __init__(self, poses, ranges, tables, successors, problem, fixed, fixed_hard, horizons=None):
        self.poses, self.ranges, self.tables = poses, ranges, tables
        self.horizons = horizons
        self.successors, self.p = successors, problem
        self.fixed, self.fixed_hard = fixed, fixed_hard
        self.shared = {}

    def others(self, g):
        rows = list(self.fixed) + [c for k, c in sorted(self.shared.items()) if k != g]
        hard = list(self.fixed_hard) + [False] * (len(rows) - len(self.fixed))
        m = self.p.np_steps
        return (np.array(rows, dtype=np.int64).reshape(-1, m, 2), np.array(hard, dtype=np.bool_))

    def __call__(self, g, rows):
        rows = np.ascontiguousarray(rows, dtype=np.int64)
        n, m = rows.shape
        scores, depths = np.empty(n), np.empty(n, dtype=np.int64)
        cells = np.zeros((n, m, 3), dtype=np.int64)
        others, hard = self.others(g)
        x, y, h, flown = (int(v) for v in self.poses[g])
        score_paths(rows, x, y, h, self.successors, self.p.tep, self.p.eu, self.p.blocked, self.p.fa_map, others, hard,
                    self.p.weights, flown, int(self.ranges[g]), self.p.move_costs, self.tables[g], self.p.tep_once,
                    scores, depths, cells)
        if self.horizons is not None and self.horizons.shape[1] > 0:
            centre = (self.horizons.shape[1] - 1) // 2
            for i in range(n):
                if depths[i] > 0:
                    last_x, last_y = cells[i, depths[i] - 1, :2]
                    scores[i] += self.horizons[g][last_x - x + centre, last_y - y + centre]
        return [(depths[i] * DEPTH_WEIGHT + scores[i], scores[i], depths[i], cells[i]) for i in range(n)]

    def share(self, g, cells, depth):
        row = np.full((self.p.np_steps, 2), -1, dtype=np.int64)
        row[:depth] = cells[:depth, :2]
        self.shared[g] = row


def decode(x, k):
    return [min(k - 1, max(0, math.floor(v + 0.5))) for v in x]


def clamp(v, k):
    return min(k - 0.5, max(-0.5, v))


def reference_pio(scorer, k, positions, compass, landmark, rp, min_flock):
    groups, flock, m = positions.shape
    X = [[list(map(float, positions[g, a])) for a in range(flock)] for g in range(groups)]
    V = [[[0.0] * m for _ in range(flock)] for _ in range(groups)]
    best = [None] * groups          # (fitness, J1, depth, choices, position)
    fit = [[0.0] * flock for _ in range(groups)]
    trace = [[] for _ in range(groups)]
    evaluations = 0

    def evaluate(g, members):
        nonlocal evaluations
        rows = [decode(X[g][a], k) for a in members]
        results = scorer(g, rows)
        evaluations += len(rows)
        for a, row, (f, s, d, c) in zip(members, rows, results):
            fit[g][a] = f
            if best[g] is None or f > best[g][0]:
                best[g] = (f, s, d, row, list(X[g][a]))
                scorer.share(g, c, d)

    def refresh(g):
        nonlocal evaluations
        if groups > 1:
            f, s, d, c = scorer(g, [best[g][3]])[0]
            best[g] = (f, s, d, best[g][3], best[g][4])
            scorer.share(g, c, d)
            evaluations += 1

    for g in range(groups):
        evaluate(g, range(flock))
        trace[g].append(best[g][1])
    for u in range(1, compass.shape[0] + 1):
        for g in range(groups):
            refresh(g)
            for a in range(flock):
                for q in range(m):
                    V[g][a][q] = V[g][a][q] * math.exp(-rp * u) + compass[u - 1, g, a, q] * (best[g][4][q] - X[g][a][q])
                    X[g][a][q] = clamp(X[g][a][q] + V[g][a][q], k)
            evaluate(g, range(flock))
            trace[g].append(best[g][1])
    n = flock
    for v in range(landmark.shape[0]):
        n_new = max(min(min_flock, n), n // 2)
        for g in range(groups):
            refresh(g)
            order = sorted(range(n), key=lambda a: -fit[g][a])[:n_new]
            X[g][:n_new] = [list(X[g][a]) for a in order]
            fit[g][:n_new] = [fit[g][a] for a in order]
            shifted = [f - min(fit[g][:n_new]) for f in fit[g][:n_new]]
            total = sum(shifted)
            w = [s / total for s in shifted] if total > 0 else [1.0 / n_new] * n_new
            centre = [sum(w[a] * X[g][a][q] for a in range(n_new)) for q in range(m)]
            for a in range(n_new):
                for q in range(m):
                    X[g][a][q] = clamp(X[g][a][q] + landmark[v, g, a, q] * (centre[q] - X[g][a][q]), k)
            evaluate(g, range(n_new))
            trace[g].append(best[g][1])
        n = n_new
    return [b[3] for b in best], np.array(trace), evaluations, np.array(X)


def reference_pso(scorer, k, positions, velocities, r1, r2, w, c1, c2):
    n, m = positions.shape
    X = positions.astype(float).copy()
    V = velocities.astype(float).copy()
    pbest, pfit = X.copy(), [-math.inf] * n
    gbest, gfit, gchoice, gscore = None, -math.inf, None, None
    trace = []
    for t in range(r1.shape[0] + 1):
        if t > 0:
            for a in range(n):
                for q in range(m):
                    v = (w * V[a, q] + c1 * r1[t - 1, a, q] * (pbest[a, q] - X[a, q])
                         + c2 * r2[t - 1, a, q] * (gbest[q] - X[a, q]))
                    V[a, q] = min(k - 1.0, max(-(k - 1.0), v))
                    X[a, q] = clamp(X[a, q] + V[a, q], k)
        rows = [decode(X[a], k) for a in range(n)]
        for a, (f, s, _depth, _cells) in enumerate(scorer(0, rows)):
            if f > pfit[a]:
                pfit[a], pbest[a] = f, X[a].copy()
            if f > gfit:
                gfit, gbest, gchoice, gscore = f, X[a].copy(), rows[a], s
        trace.append(gscore)
    return gchoice, np.array(trace), n * (r1.shape[0] + 1), X


def reference_ga(scorer, population, tournaments, crossover, masks, mutations, values, rate, mutation_rate, elites):
    pop = [list(map(int, row)) for row in population]
    n = len(pop)
    results = scorer(0, pop)
    fit = [r[0] for r in results]
    score = [r[1] for r in results]
    b = max(range(n), key=lambda a: (fit[a], -a))
    best = (fit[b], score[b], pop[b])
    trace = [score[b]]
    evaluations = n
    for t in range(tournaments.shape[0]):
        order = sorted(range(n), key=lambda a: -fit[a])
        children = [list(pop[a]) for a in order[:elites]]
        cfit = [fit[a] for a in order[:elites]]
        cscore = [score[a] for a in order[:elites]]
        for a in range(elites, n):
            i0, i1, i2, i3 = (int(v) for v in tournaments[t, a])
            pa = i0 if fit[i0] >= fit[i1] else i1
            pb = i2 if fit[i2] >= fit[i3] else i3
            child = []
            for q in range(len(pop[0])):
                gene = pop[pa][q]
                if crossover[t, a] < rate and masks[t, a, q] >= 0.5:
                    gene = pop[pb][q]
                if mutations[t, a, q] < mutation_rate:
                    gene = int(values[t, a, q])
                child.append(gene)
            children.append(child)
        for f, s, _, _ in scorer(0, children[elites:]):
            cfit.append(f)
            cscore.append(s)
        evaluations += n - elites
        pop, fit, score = children, cfit, cscore
        for a in range(n):
            if fit[a] > best[0]:
                best = (fit[a], score[a], pop[a])
        trace.append(best[1])
    return best[2], np.array(trace), evaluations
