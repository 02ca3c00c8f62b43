"""Streets as a graph and a car that drives them (pure numpy): the road network of a city of
blocks, a route planner that revisits places (loop closures) and the drive along the route
(lanes, turns at intersections, stops, speed profile), sampled at the camera's frame rate.

Ground coordinates are the SES world's (x, z) (Y up: a heading (hx, hz) of (0, -1) looks
along -z, as an unrotated camera); the road surface is y = 0. Traffic keeps right: a car on
the directed street a -> b drives on the lane ``lane`` metres right of the street's axis.

- :class:`RoadGraph`: intersections (nodes) joined by straight street segments (edges);
  :class:`BlockGrid` / :func:`irregular_grid`: a city of rectangular blocks of random sizes,
  some of them joined (a street segment left out: T-junctions), no dead ends.
- :func:`plan_route`: a walk on the graph that drives like a car -- no U-turns, turns only at
  intersections -- of at least ``length_m``, returning ``closures`` times to a street driven
  long before (in the same or the opposite direction); every other street it drives once.
- :func:`drive`: the route as a path (lane centre lines joined by circular turns at the
  intersections), a speed profile (top speed, lateral-acceleration limit in turns,
  acceleration and braking limits, stops at intersections), sampled at the frame times.
- :func:`closure_events`: the loop closures a drive contains, measured on its clock.
"""
from __future__ import annotations

import heapq
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

DIRECTIONS = ("same", "opposite", "mixed")


def right_of(h: np.ndarray) -> np.ndarray:
    """The ground direction to the right of heading ``h`` (x, z), Y up."""
    h = np.asarray(h, float)
    return np.array([-h[..., 1], h[..., 0]]).T if h.ndim > 1 else np.array([-h[1], h[0]])


def turn_angle(h1: np.ndarray, h2: np.ndarray) -> float:
    """Signed angle (rad) from heading h1 to h2, left turns positive (seen from above)."""
    cross = h1[0] * h2[1] - h1[1] * h2[0]
    return float(-np.arctan2(cross, float(np.dot(h1, h2))))


def yaw_deg(h) -> np.ndarray:
    """The camera yaw (deg, left positive, 0 = looking along -z) of ground headings h (..., 2)."""
    h = np.asarray(h, float)
    return np.degrees(np.arctan2(-h[..., 0], -h[..., 1]))


# --- the graph ---------------------------------------------------------------------------

@dataclass(frozen=True)
class RoadGraph:
    """Intersections ``nodes`` (n, 2) ground (x, z) joined by straight two-way streets
    ``edges`` (undirected, a < b). Streets are ``2 * half_road`` wide; cars drive ``lane``
    right of the axis. Around every node the square of half size ``half_road`` is the
    junction's asphalt."""
    nodes: np.ndarray
    edges: tuple
    half_road: float = 5.0
    lane: float = 1.75

    def __post_init__(self):
        adj: dict[int, list[int]] = {i: [] for i in range(len(self.nodes))}
        for a, b in self.edges:
            adj[a].append(b)
            adj[b].append(a)
        object.__setattr__(self, "adjacency", {k: tuple(sorted(v)) for k, v in adj.items()})

    def key(self, a: int, b: int) -> tuple[int, int]:
        """The undirected edge of a directed one."""
        return (a, b) if a < b else (b, a)

    def length(self, a: int, b: int) -> float:
        return float(np.linalg.norm(self.nodes[b] - self.nodes[a]))

    def heading(self, a: int, b: int) -> np.ndarray:
        d = self.nodes[b] - self.nodes[a]
        return d / np.linalg.norm(d)

    def lane_line(self, a: int, b: int) -> tuple[np.ndarray, np.ndarray]:
        """(point at node a's cross-section, heading) of the lane of the directed street a -> b."""
        h = self.heading(a, b)
        return self.nodes[a] + self.lane * right_of(h), h

    def successors(self, a: int, b: int) -> tuple[int, ...]:
        """Nodes a car may drive to from b having come from a: no U-turn unless b is a dead end."""
        nxt = tuple(c for c in self.adjacency[b] if c != a)
        return nxt or (a,)

    @property
    def total_length(self) -> float:
        return float(sum(self.length(a, b) for a, b in self.edges))


def grid_graph(xs, zs, drop=(), half_road: float = 5.0, lane: float = 1.75) -> RoadGraph:
    """Streets along x = xs[i] and z = zs[j] (a grid of blocks); node (i, j) is index
    i * len(zs) + j; ``drop``: undirected edges (a, b) left out."""
    xs, zs = np.asarray(xs, float), np.asarray(zs, float)
    nz = len(zs)
    nodes = np.array([(x, z) for x in xs for z in zs])
    drop = {tuple(sorted(e)) for e in drop}
    edges = []
    for i in range(len(xs)):
        for j in range(nz):
            a = i * nz + j
            for b in ((i + 1) * nz + j if i + 1 < len(xs) else None, a + 1 if j + 1 < nz else None):
                if b is not None and (a, b) not in drop:
                    edges.append((a, b))
    return RoadGraph(nodes, tuple(edges), half_road, lane)


@dataclass(frozen=True)
class BlockGrid:
    """A city of rectangular blocks: streets along x = ``xs[i]`` and z = ``zs[j]`` (their axes),
    but for the segments in ``dropped`` (pairs of node indices, node (i, j) being
    ``i * len(zs) + j``), where two neighbouring blocks are one."""
    xs: np.ndarray
    zs: np.ndarray
    dropped: frozenset = frozenset()
    half_road: float = 5.0
    lane: float = 1.75

    @property
    def graph(self) -> RoadGraph:
        return grid_graph(self.xs, self.zs, self.dropped, self.half_road, self.lane)

    def _separating(self, a: int, b: int) -> tuple:
        """The two cells (i, j) on either side of the segment between nodes a and b."""
        n1z = len(self.zs)
        (ia, ja), (_, jb) = divmod(min(a, b), n1z), divmod(max(a, b), n1z)
        if ja == jb:                       # along x, at z = zs[ja]
            return (ia, ja - 1), (ia, ja)
        return (ia - 1, ja), (ia, ja)      # along z, at x = xs[ia]

    def blocks(self) -> list[tuple[float, float, float, float]]:
        """(x0, x1, z0, z1) between street axes of every block (merged cells as one)."""
        merged = {}
        for a, b in self.dropped:
            c1, c2 = self._separating(a, b)
            merged[c1] = merged[c2] = (min(c1, c2), max(c1, c2))
        out, seen = [], set()
        for i in range(len(self.xs) - 1):
            for j in range(len(self.zs) - 1):
                c1, c2 = merged.get((i, j), ((i, j), (i, j)))
                if c1 in seen:
                    continue
                seen.add(c1)
                out.append((float(self.xs[c1[0]]), float(self.xs[c2[0] + 1]), float(self.zs[c1[1]]),
                            float(self.zs[c2[1] + 1])))
        return out


def irregular_grid(rng: np.random.Generator, nx: int, nz: int, block=(70.0, 110.0), drop_fraction: float = 0.12,
                   half_road: float = 5.0, lane: float = 1.75) -> BlockGrid:
    """A grid of ``nx`` x ``nz`` blocks whose sides are drawn from ``block`` (m), centred on the
    origin, with about ``drop_fraction`` of the inner street segments left out: each joins two
    blocks into one (a block is joined at most once, so blocks stay rectangles) and leaves
    T-junctions, never a dead end or a bend (both ends keep three streets)."""
    xs = np.concatenate([[0.0], np.cumsum(rng.uniform(*block, nx))])
    zs = np.concatenate([[0.0], np.cumsum(rng.uniform(*block, nz))])
    xs, zs = np.round(xs - xs[-1] / 2, 2), np.round(zs - zs[-1] / 2, 2)
    full = BlockGrid(xs, zs, frozenset(), half_road, lane)
    g = full.graph
    n1z = nz + 1
    inner = [e for e in g.edges
             if not (divmod(e[0], n1z)[0] == divmod(e[1], n1z)[0] in (0, nx)
                     or divmod(e[0], n1z)[1] == divmod(e[1], n1z)[1] in (0, nz))]
    degree = {n: len(g.adjacency[n]) for n in g.adjacency}
    used_cells, dropped = set(), set()
    for i in rng.permutation(len(inner))[:int(round(drop_fraction * len(inner)))]:
        a, b = inner[i]
        cells = full._separating(a, b)
        if degree[a] > 3 and degree[b] > 3 and not (set(cells) & used_cells):
            dropped.add((a, b))
            used_cells |= set(cells)
            degree[a] -= 1
            degree[b] -= 1
    return BlockGrid(xs, zs, frozenset(dropped), half_road, lane)


# --- routes ------------------------------------------------------------------------------

@dataclass
class Route:
    """A walk on a graph: ``nodes`` n0, n1, ... (consecutive ones joined by an edge);
    ``planned_closures``: route indices of the edges where a planned return begins."""
    nodes: list
    planned_closures: list = field(default_factory=list)

    @property
    def edges(self) -> list[tuple[int, int]]:
        return list(zip(self.nodes[:-1], self.nodes[1:]))

    def length(self, g: RoadGraph) -> float:
        return float(sum(g.length(a, b) for a, b in self.edges))


class RouteError(ValueError):
    """No route with the requested properties was found on this graph."""


def plan_route(g: RoadGraph, rng: np.random.Generator, length_m: float, closures: int = 0,
               gap_m: float = 300.0, direction: str = "mixed", revisit_edges: int = 1,
               tries: int = 400, candidates: int = 12) -> Route:
    """A route of at least ``length_m`` metres (whole edges) that drives like a car (no U-turn,
    turns at intersections) and returns ``closures`` times to a street it drove at least
    ``gap_m`` metres of route earlier, re-driving ``revisit_edges`` street segments there in
    the ``direction`` it drove them before (``same``), against it (``opposite``) or
    alternately (``mixed``, the first return the same way). Every other street is driven
    once, so the route's repeated streets are exactly its planned returns
    (:func:`repeated_runs`). Of the first ``candidates`` such routes found (random walks),
    the shortest. Raises :class:`RouteError` when none is found in ``tries`` attempts (the
    graph too small for the length)."""
    if direction not in DIRECTIONS:
        raise ValueError(f"direction must be one of {', '.join(DIRECTIONS)}, got {direction!r}")
    if closures < 0 or revisit_edges < 1:
        raise ValueError("closures must be >= 0 and revisit_edges >= 1")
    found = []
    for _ in range(tries):
        route = _attempt(g, rng, float(length_m), int(closures), float(gap_m), direction, int(revisit_edges))
        if route is not None and len(repeated_runs(g, route.edges)) == closures:
            found.append(route)
            if len(found) == candidates:
                break
    if found:    # the shortest of the routes found (the first of equals)
        return min(found, key=lambda r: r.length(g))
    raise RouteError(f"no route of {length_m:g} m with {closures} loop closure(s) {gap_m:g} m apart found on a "
                     f"graph of {g.total_length:.0f} m of streets: use a larger city (more blocks)")


def _attempt(g: RoadGraph, rng, length_m, closures, gap_m, direction, revisit) -> Optional[Route]:
    a = int(rng.integers(len(g.nodes)))
    b = int(rng.choice(g.adjacency[a]))
    nodes = [a, b]
    dist = [0.0, g.length(a, b)]                   # route distance at each node
    visits: dict = {g.key(a, b): [0]}              # undirected edge -> route edge indices
    planned = []
    done = 0
    # returns spread over the route, the first as soon as a street lies gap_m behind
    span = max(length_m - gap_m, 0.0)
    marks = [gap_m + span * k / (closures + 0.5) for k in range(closures)]
    while dist[-1] < length_m or done < closures:
        if done < closures and dist[-1] >= marks[done]:
            back = _return_path(g, nodes, dist, visits, gap_m, direction, done, revisit)
            if back is not None:     # else: drive on and try again at the next junction
                planned.append(len(nodes) - 1 + back[1])
                for n in back[0]:
                    _append(g, nodes, dist, visits, n)
                done += 1
                continue
        nxt = _explore_step(g, nodes, visits, rng)
        if nxt is None:
            return None
        _append(g, nodes, dist, visits, nxt)
        if dist[-1] > 4 * length_m + 2000:
            return None
    return Route(nodes, planned)


def _append(g, nodes, dist, visits, n):
    a = nodes[-1]
    visits.setdefault(g.key(a, n), []).append(len(nodes) - 1)
    nodes.append(n)
    dist.append(dist[-1] + g.length(a, n))


def _free_region(g: RoadGraph, start: int, via, visits) -> int:
    """Number of never-driven edges reachable from node ``start`` over never-driven edges
    (``via``: the edge about to be driven counts as driven)."""
    seen_e, seen_n, todo = {via}, {start}, [start]
    while todo:
        n = todo.pop()
        for m in g.adjacency[n]:
            e = g.key(n, m)
            if e in visits or e in seen_e:
                continue
            seen_e.add(e)
            if m not in seen_n:
                seen_n.add(m)
                todo.append(m)
    return len(seen_e) - 1


def _explore_step(g: RoadGraph, nodes, visits, rng) -> Optional[int]:
    """The next node of an exploring car: a street never driven, keeping the largest region of
    undriven streets ahead, preferring to go straight; None when every way is driven."""
    a, b = nodes[-2], nodes[-1]
    h = g.heading(a, b)
    cands = [c for c in g.successors(a, b) if g.key(b, c) not in visits]
    if not cands:
        return None
    region = np.array([_free_region(g, c, g.key(b, c), visits) for c in cands], float)
    keep = region >= 0.6 * region.max()
    cands = [c for c, k in zip(cands, keep) if k]
    w = np.array([0.55 if abs(turn_angle(h, g.heading(b, c))) < 0.3 else 0.3 for c in cands])
    return int(cands[int(rng.choice(len(cands), p=w / w.sum()))])


def _return_path(g: RoadGraph, nodes, dist, visits, gap_m, direction, k, revisit):
    """(nodes to append, index among them of the first revisited edge's start) of the way back
    to a street driven at least ``gap_m`` of route ago, over streets never driven, then
    ``revisit`` edges along the old drive; None if there is none."""
    edges = list(zip(nodes[:-1], nodes[1:]))
    same = direction == "same" or (direction == "mixed" and k % 2 == 0)
    # candidate old stretches: ``revisit`` consecutive old edges, all long enough ago
    targets = {}
    for i in range(len(edges) - revisit + 1):
        if dist[-1] - dist[i + revisit] < gap_m:
            break
        run = edges[i:i + revisit]
        if any(len(visits[g.key(*e)]) > 1 for e in run):
            continue                                     # driven twice already
        if not all(_turn_ok(g, run[j], run[j + 1]) for j in range(revisit - 1)):
            continue
        seq = run if same else [(b, a) for a, b in reversed(run)]
        if not same and not all(_turn_ok(g, seq[j], seq[j + 1]) for j in range(revisit - 1)):
            continue
        targets[seq[0]] = seq
    if not targets:
        return None
    # Dijkstra over directed edges from the current one; never-driven streets only
    start = (nodes[-2], nodes[-1])
    best = {start: 0.0}
    prev = {}
    heap = [(0.0, start)]
    found = None
    while heap:
        cost, (a, b) = heapq.heappop(heap)
        if cost > best.get((a, b), np.inf):
            continue
        if (a, b) != start and (a, b) in targets:
            found = (a, b)
            break
        for c in g.successors(a, b):
            e = (b, c)
            w = 1.0
            if e not in targets and g.key(b, c) in visits:
                # an old street may lead to the target (part of the same return), a recent one not
                if dist[-1] - dist[visits[g.key(b, c)][-1] + 1] < gap_m or len(visits[g.key(b, c)]) > 1:
                    continue
                w = 4.0
            nc = cost + w * g.length(b, c)
            if nc < best.get(e, np.inf):
                best[e] = nc
                prev[e] = (a, b)
                heapq.heappush(heap, (nc, e))
    if found is None:
        return None
    way = [found]
    while way[-1] != start:
        way.append(prev[way[-1]])
    way = way[::-1][1:]                                  # directed edges after the current one
    seq = targets[found]
    out = [e[1] for e in way[:-1]] + [e[1] for e in seq]
    return out, len(way) - 1


def _turn_ok(g: RoadGraph, e1, e2) -> bool:
    return e1[1] == e2[0] and e2[1] in g.successors(*e1)


def random_walk(g: RoadGraph, rng: np.random.Generator, length_m: float) -> Route:
    """A car's random drive of at least ``length_m``: from a random street, at every junction
    straight on (weight 0.55) or a turn (0.3 each), never back."""
    a = int(rng.integers(len(g.nodes)))
    nodes = [a, int(rng.choice(g.adjacency[a]))]
    total = g.length(*nodes)
    while total < length_m:
        a, b = nodes[-2], nodes[-1]
        h = g.heading(a, b)
        cands = g.successors(a, b)
        w = np.array([0.55 if abs(turn_angle(h, g.heading(b, c))) < 0.3 else 0.3 for c in cands])
        c = int(cands[int(rng.choice(len(cands), p=w / w.sum()))])
        nodes.append(c)
        total += g.length(b, c)
    return Route(nodes)


def repeated_runs(g: RoadGraph, edges) -> list[tuple[int, int]]:
    """(first, last) route-edge indices of each maximal run of consecutive edges that were
    driven before (in either direction)."""
    seen, runs = set(), []
    for i, (a, b) in enumerate(edges):
        k = g.key(a, b)
        if k in seen:
            if runs and runs[-1][1] == i - 1:
                runs[-1] = (runs[-1][0], i)
            else:
                runs.append((i, i))
        seen.add(k)
    return runs


# --- the drive ---------------------------------------------------------------------------

@dataclass(frozen=True)
class DriveParams:
    """How the car drives: top speed (m/s), turn radii of right and left turns (m), lateral
    acceleration limit in turns, acceleration and braking (m/s^2), the share of
    intersections where it stops and for how long (s), the path's sampling step (m)."""
    v_max: float = 11.0
    r_right: float = 6.0
    r_left: float = 9.0
    a_lat: float = 2.0
    a_acc: float = 1.8
    a_dec: float = 2.5
    p_stop: float = 0.25
    dwell_s: tuple = (1.0, 3.0)
    step_m: float = 0.2
    start_m: float = 12.0          # where the drive starts on the route's first street, from its first node


@dataclass
class Path:
    """A route's path sampled every ``step`` metres: arc length ``s``, ground points ``xz``,
    unit headings ``h``, signed curvature ``kappa`` (1/m, left positive), the route edge
    each sample lies on (``edge``), and the arc lengths where the route passes its nodes."""
    s: np.ndarray
    xz: np.ndarray
    h: np.ndarray
    kappa: np.ndarray
    edge: np.ndarray
    node_s: np.ndarray
    stop_s: np.ndarray

    def at(self, s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(points (n, 2), headings (n, 2), curvature (n,)) at arc lengths ``s``."""
        s = np.asarray(s, float)
        xz = np.stack([np.interp(s, self.s, self.xz[:, i]) for i in range(2)], axis=-1)
        h = np.stack([np.interp(s, self.s, self.h[:, i]) for i in range(2)], axis=-1)
        h /= np.linalg.norm(h, axis=-1, keepdims=True)
        return xz, h, np.interp(s, self.s, self.kappa)


def route_path(g: RoadGraph, route: Route, p: DriveParams, rng: np.random.Generator, length_m=None) -> Path:
    """The path a car drives along ``route``: each street on its lane's centre line, each
    turn a circular arc tangent to both lanes (radius ``r_right`` or ``r_left``), straight on
    across a junction; it starts ``p.start_m`` along the first street and ends after
    ``length_m`` (default: the end of the route). Stops: before a junction, with probability
    ``p.p_stop``, at the lane point ``half_road + 3`` m before the junction's centre (or
    just before the turn begins)."""
    edges = route.edges
    pieces = []        # ("line", p0, h, L, edge) | ("arc", p0, h0, angle, R, edge)
    cur = None         # where the current straight begins
    stops = []
    for k, (a, b) in enumerate(edges):
        q, h = g.lane_line(a, b)
        if cur is None:
            cur = q + p.start_m * h
        end = q + g.length(a, b) * h                     # the lane point level with node b
        if k + 1 < len(edges):
            q2, h2 = g.lane_line(*edges[k + 1])
            ang = turn_angle(h, h2)
            if abs(ang) < 1e-6:
                seg_end, arc = end, None
            else:
                # the lanes meet at P; the fillet of radius R starts d before it
                R = p.r_left if ang > 0 else p.r_right
                d = R * np.tan(abs(ang) / 2)
                A = np.array([h, -h2]).T
                t, _ = np.linalg.solve(A, q2 - q)
                P = q + t * h
                seg_end, arc = P - d * h, (ang, R)
        else:
            seg_end, arc = end, None
        L = float(np.dot(seg_end - cur, h))
        if L < -1e-6:
            raise RouteError("a street is too short for its turns")
        pieces.append(("line", cur, h, max(L, 0.0), k))
        back = g.half_road + 3.0
        stop_d = float(np.dot(end - cur, h)) - back
        if k + 1 < len(edges) and rng.uniform() < p.p_stop:
            stops.append((len(pieces) - 1, max(min(stop_d, L - 0.5), 0.0)))
        if arc is not None:
            ang, R = arc
            pieces.append(("arc", seg_end, h, ang, R, k + 1))
            cur = seg_end + R * np.tan(abs(ang) / 2) * (h + g.heading(*edges[k + 1]))
            # (the tangent point on the next lane: P + d h2 = seg_end + d h + d h2)
        else:
            cur = seg_end
    # sample
    S, XZ, Hs, KAP, E, node_s, stop_s = [], [], [], [], [], [], []
    s0 = 0.0
    for i, pc in enumerate(pieces):
        if pc[0] == "line":
            _, p0, h, L, k = pc
            n = max(int(np.ceil(L / p.step_m)), 1)
            u = np.linspace(0.0, L, n + 1)[:-1] if i + 1 < len(pieces) else np.linspace(0.0, L, n + 1)
            S.append(s0 + u)
            XZ.append(p0 + u[:, None] * h)
            Hs.append(np.tile(h, (len(u), 1)))
            KAP.append(np.zeros(len(u)))
            E.append(np.full(len(u), k))
            a, b = edges[k]
            node_s.append(s0 + float(np.dot(g.nodes[b] - p0, h)))
            stop_s += [s0 + d for j, d in stops if j == i]
            s0 += L
        else:
            _, p0, h0, ang, R, k = pc
            arc_len = R * abs(ang)
            n = max(int(np.ceil(arc_len / p.step_m)), 2)
            u = np.linspace(0.0, arc_len, n + 1)[:-1]
            side = np.sign(ang)
            centre = p0 - side * R * right_of(h0)            # left turn: the centre is on the left
            c, sn = np.cos(ang * u / arc_len), np.sin(ang * u / arc_len)
            rel = p0 - centre                                  # turned left by the arc's angle so far
            pts = centre + np.column_stack([c * rel[0] + sn * rel[1], -sn * rel[0] + c * rel[1]])
            hh = np.column_stack([c * h0[0] + sn * h0[1], -sn * h0[0] + c * h0[1]])
            S.append(s0 + u)
            XZ.append(pts)
            Hs.append(hh)
            KAP.append(np.full(len(u), side / R))
            E.append(np.full(len(u), k))
            s0 += arc_len
    S = np.concatenate(S)
    keep = np.concatenate([[True], np.diff(S) > 1e-6])        # a zero-length straight adds no sample
    path = Path(S[keep], np.concatenate(XZ)[keep], np.concatenate(Hs)[keep], np.concatenate(KAP)[keep],
                np.concatenate(E).astype(int)[keep], np.array(node_s), np.array(sorted(stop_s)))
    if length_m is not None and length_m < path.s[-1]:
        keep = path.s <= length_m + 1e-9
        path = Path(path.s[keep], path.xz[keep], path.h[keep], path.kappa[keep], path.edge[keep],
                    path.node_s, path.stop_s[path.stop_s < length_m - 1.0])
    return path


@dataclass
class Drive:
    """A drive sampled at the frame times ``t`` (s): arc length ``s``, ground points ``xz``,
    headings ``h``, speed ``v`` (m/s), longitudinal and lateral acceleration (m/s^2), the
    route edge of each frame; ``edge_t``: (entry, exit) time of each route edge (s, NaN for
    edges the drive does not reach)."""
    t: np.ndarray
    s: np.ndarray
    xz: np.ndarray
    h: np.ndarray
    v: np.ndarray
    a_long: np.ndarray
    a_lat: np.ndarray
    edge: np.ndarray
    edge_t: np.ndarray
    duration_s: float


def speed_profile(path: Path, p: DriveParams, rng: np.random.Generator, v_start: float = 0.0) -> tuple:
    """(v at every path sample, dwell time at every sample): the fastest speed within the top
    speed and the lateral-acceleration limit in turns that the acceleration and braking
    limits allow, 0 at the stops (which wait ``p.dwell_s``) and at the end."""
    s, kap = path.s, np.abs(path.kappa)
    v = np.minimum(p.v_max, np.sqrt(p.a_lat / np.maximum(kap, 1e-12)))
    dwell = np.zeros(len(s))
    for ss in path.stop_s:
        i = int(np.searchsorted(s, ss))
        if s[0] + 5.0 < ss < s[-1] - 5.0 and v[i - 1] > 0:
            v[i] = 0.0
            dwell[i] = float(rng.uniform(*p.dwell_s))
    v[0] = min(v[0], v_start)
    v[-1] = 0.0
    vl, ds = v.tolist(), np.diff(s).tolist()        # plain floats: the passes are sequential
    for i in range(len(vl) - 1):                    # accelerating
        vl[i + 1] = min(vl[i + 1], (vl[i] * vl[i] + 2 * p.a_acc * ds[i]) ** 0.5)
    for i in range(len(vl) - 2, -1, -1):            # braking
        vl[i] = min(vl[i], (vl[i + 1] * vl[i + 1] + 2 * p.a_dec * ds[i]) ** 0.5)
    return np.array(vl), dwell


def drive(g: RoadGraph, route: Route, rate_hz: float, p: DriveParams = DriveParams(),
          rng: Optional[np.random.Generator] = None, length_m=None, v_start: float = 0.0,
          t_offset: float = 0.0, frames: Optional[int] = None) -> Drive:
    """The car's state at the frame times k / rate_hz + ``t_offset`` (k = 0 .. until it stops at
    the end, or ``frames`` frames) along ``route`` (see :func:`route_path`, :func:`speed_profile`);
    the motion between path samples is at constant acceleration."""
    rng = np.random.default_rng(0) if rng is None else rng
    path = route_path(g, route, p, rng, length_m)
    v, dwell = speed_profile(path, p, rng, v_start)
    ds = np.diff(path.s)
    with np.errstate(divide="ignore", invalid="ignore"):
        dt = np.where(v[:-1] + v[1:] > 0, 2 * ds / (v[:-1] + v[1:]), np.inf)
    if not np.all(np.isfinite(dt)):
        raise RouteError("the drive cannot move (zero speed between two path samples)")
    t_arrive = np.concatenate([[0.0], np.cumsum(dt + dwell[:-1])])   # time the car reaches sample i
    t_leave = t_arrive + dwell
    T = float(t_leave[-1])
    n = int(np.floor((T - t_offset) * rate_hz + 1e-9)) + 1 if frames is None else int(frames)
    t = t_offset + np.arange(n) / rate_hz
    if frames is None:
        t = t[t <= T + 1e-9]
    i = np.clip(np.searchsorted(t_leave, t, side="right") - 1, 0, len(path.s) - 2)
    travel = t_arrive[i + 1] - t_leave[i]
    moving = (t - t_leave[i] < travel) & (t < T)      # else waiting at sample i + 1 (a stop) or arrived
    tau = np.clip(np.minimum(t - t_leave[i], travel), 0.0, None)
    a = (v[i + 1] ** 2 - v[i] ** 2) / (2 * ds[i])
    s = np.minimum(path.s[i] + v[i] * tau + 0.5 * a * tau ** 2, path.s[-1])
    vel = np.where(moving, np.clip(v[i] + a * tau, 0.0, None), 0.0)
    a = np.where(moving, a, 0.0)
    xz, h, kappa = path.at(s)
    # times the drive enters and leaves each route edge
    n_edges = len(route.edges)
    edge_t = np.full((n_edges, 2), np.nan)
    starts = np.concatenate([[0.0], path.node_s[:-1]])
    for k in range(n_edges):
        for j, sk in enumerate((starts[k] if k else path.s[0], path.node_s[k] if k < len(path.node_s) else np.inf)):
            if sk <= path.s[-1]:
                ii = int(np.clip(np.searchsorted(path.s, sk), 0, len(path.s) - 1))
                edge_t[k, j] = t_arrive[ii] if j == 0 else t_leave[ii]
    return Drive(t=t, s=s, xz=xz, h=h, v=vel, a_long=a, a_lat=vel ** 2 * kappa,
                 edge=path.edge[np.clip(np.searchsorted(path.s, s, side="right") - 1, 0, len(path.s) - 1)],
                 edge_t=edge_t, duration_s=T)


@dataclass(frozen=True)
class Closure:
    """A loop closure: route edges ``first`` .. ``last`` re-drive streets last driven
    ``gap_s`` seconds before (the earlier drive of ``first``'s street ended at ``t_before``,
    the return starts at ``t_after``), in the ``same`` direction or not."""
    first: int
    last: int
    t_before: float
    t_after: float
    same: bool

    @property
    def gap_s(self) -> float:
        return self.t_after - self.t_before


def closure_events(g: RoadGraph, route: Route, d: Drive, gap_s: float) -> list[Closure]:
    """The loop closures of a drive: maximal runs of consecutive route edges each of which
    was driven before, the last time at least ``gap_s`` seconds before (edges the drive does
    not reach are ignored)."""
    last_exit: dict = {}
    last_dir: dict = {}
    out: list[Closure] = []
    for i, (a, b) in enumerate(route.edges):
        t_in, t_out = d.edge_t[i]
        if not np.isfinite(t_in):
            break
        key = g.key(a, b)
        if key in last_exit and t_in - last_exit[key] >= gap_s:
            same = last_dir[key] == (a, b)
            if out and out[-1].last == i - 1:
                out[-1] = Closure(out[-1].first, i, out[-1].t_before, out[-1].t_after, out[-1].same)
            else:
                out.append(Closure(i, i, last_exit[key], float(t_in), same))
        last_exit[key] = float(t_out) if np.isfinite(t_out) else float(d.duration_s)
        last_dir[key] = (a, b)
    return out
