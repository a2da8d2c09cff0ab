#!/usr/bin/python3
"""How much of a step's impulse error a coarse space could remove (docs/step-error.md, "What a
coarse correction could reach").

Reads the samples that `cdshear_bench --step-error N --dump-samples DIR` writes (each sample's
contacts with the tested and the reference impulses, and the bodies) and, on the reference's
force-carrying contacts, with e = R_tested - R_reference and A = M^-1/2 H^T (|A R|^2 is twice the
kinetic energy R gives; W = A^T A is the Delassus operator), prints for a space P two shares of
|e|, as "galerkin / span": what is left after the Galerkin correction, that is after removing
e's W-orthogonal projection P (P^T W P)^+ P^T W e (what one exact coarse solve of the step
linearised with every force-carrying contact's two rows as equalities would remove; sliding
contacts are not), and what lies outside span P (e less its orthogonal projection: what the best
correction within P could leave, by any method); then, after "v", the share of the error's
velocities |A e| (what the grains feel; |A e|^2 = e^T W e) left after the Galerkin correction,
which of all corrections within P leaves the least of it:

- stress CELL: smooth stress fields, three per node (sigma_xx, sigma_yy, sigma_xy) of a grid of
  CELL x CELL cells (periodic in x, nodes on both walls) with bilinear hats: a contact's impulse
  is phi_K(contact point) E l, E the stress component's unit tensor, l the branch vector;
- scale CELL: one per node, the reference impulses scaled by phi_K (a per-node scaling of the
  impulses, as the slab correction does per band, given the answer's own pattern: its best case);
- lowest K: the K eigenvectors of W with the smallest eigenvalues (the null space first: a
  Galerkin correction leaves e's null-space part, which only the span share counts as removable;
  printed first, the share of |e| in the null space, eigenvalues below 1e-10 of the largest);
- with --stale: the first sample's lowest K eigenvectors, carried over to each later sample's
  contacts by their pair of bodies (a space computed once and reused).

DIR is one case's folder, DIR_GIVEN/<case>_n<disks> (`shear_n2047` for a prepared packing).

  cdshear_bench --packing P --velocity V --no-static --steps 100 --warmup 2000 --step-error 6 \
      --reference-relaxation 1.6 --reference-anderson 5 --dump-samples DIR
  /usr/bin/python3 bench/coarse_space.py DIR/shear_nN --cells 8,4,2 --lowest 30,100,300 [--stale]
"""

import argparse
import glob

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

# Columns of sample_K_contacts.txt (cdshear_bench's dump_sample).
BODY_A, BODY_B, NX, NY, LEVER_A, LEVER_B, ARM_X, ARM_Y = 0, 1, 2, 3, 4, 5, 6, 7
GAP, FRICTION = 8, 9
TESTED_N, TESTED_T, REFERENCE_N, REFERENCE_T = 10, 11, 12, 13
# Columns of sample_K_bodies.txt: 1/m along x and y, 1/I.
INV_MASS = slice(2, 5)
# W's null space: eigenvalues below this share of its largest (self-stresses, to round-off).
NULL_LEVEL = 1e-10


def contact_jacobian(contacts, bodies):
    """H, u = H v: row 2k the normal relative velocity of contact k (body A's less body B's), 2k + 1
    the tangential one; columns 3b, 3b + 1, 3b + 2 body b's v_x, v_y, omega."""
    rows, cols, vals = [], [], []
    for k, r in enumerate(contacts):
        n = r[[NX, NY]]
        t = np.array([-n[1], n[0]])
        for body, sign, lever in ((int(r[BODY_A]), 1.0, r[LEVER_A]),
                                  (int(r[BODY_B]), -1.0, r[LEVER_B])):
            rows += [2 * k, 2 * k, 2 * k + 1, 2 * k + 1, 2 * k + 1]
            cols += [3 * body, 3 * body + 1, 3 * body, 3 * body + 1, 3 * body + 2]
            vals += [sign * n[0], sign * n[1], sign * t[0], sign * t[1], lever]
    return sp.csr_matrix((vals, (rows, cols)), shape=(2 * len(contacts), 3 * len(bodies)))


def sample_header(stem):
    """The first line of STEM_contacts.txt (`cdshear_bench --dump-samples`): L_x, the bottom and
    top walls' y and the time step, as a list of floats (older dumps stop before the time step)."""
    with open(stem + "_contacts.txt") as f:
        return [float(x) for x in f.readline()[2:].split()]


def sample_stems(folder):
    """The samples `cdshear_bench --dump-samples` wrote to FOLDER (DIR/<case>_n<disks>), as
    FOLDER/sample_K in the order of K; none is an error."""
    stems = sorted((f[: -len("_contacts.txt")]
                    for f in glob.glob(folder + "/sample_*_contacts.txt")),
                   key=lambda s: int(s.split("_")[-1]))
    if not stems:
        raise SystemExit(f"error: {folder}: no sample_K_contacts.txt "
                         "(cdshear_bench --dump-samples)")
    return stems


def contact_status(normal, tangential, friction, open_below=0.0, slide_tolerance=1e-9):
    """0 open (R_n <= open_below), 1 sticking, 2 sliding (|R_t| at mu R_n to a relative
    slide_tolerance)."""
    sliding = np.abs(tangential) >= friction * normal * (1.0 - slide_tolerance)
    return np.where(normal <= open_below, 0, np.where(sliding, 2, 1))


# Columns of sample_K_bodies.txt: v_x, v_y, omega after the reference solve.
VELOCITY = slice(5, 8)


class StepProblem:
    """One dumped step as its contact problem over every candidate contact: u = W R + q at any R
    (W = H M^-1 H^T the Delassus operator, q the free term with gap / dt on the normal rows, both
    formed from the dump alone: q = u_ref - W R_ref), mu per contact, and the tested and the
    reference impulses (n, t interleaved)."""

    def __init__(self, stem):
        header = sample_header(stem)
        if len(header) < 4:
            raise SystemExit(f"error: {stem}_contacts.txt: no time step on its first line "
                             "(dumped by an older bench)")
        self.dt = float(header[3])
        contacts = np.loadtxt(stem + "_contacts.txt", comments="#", ndmin=2)
        bodies = np.loadtxt(stem + "_bodies.txt", comments="#", ndmin=2)
        if bodies.shape[1] < VELOCITY.stop:
            raise SystemExit(f"error: {stem}_bodies.txt: no velocities (dumped by an older bench)")
        h = contact_jacobian(contacts, bodies)
        self.w = (h @ sp.diags(bodies[:, INV_MASS].ravel()) @ h.T).tocsc()
        self.reference = contacts[:, [REFERENCE_N, REFERENCE_T]].ravel()
        self.tested = contacts[:, [TESTED_N, TESTED_T]].ravel()
        self.mu = contacts[:, FRICTION]
        self.contacts = contacts  # the dump's rows, columns as above
        self.bodies = bodies  # the dump's rows: x, y, 1/m along x and y, 1/I, velocities
        self.q = h @ bodies[:, VELOCITY].ravel() - self.w @ self.reference
        self.q[0::2] += contacts[:, GAP] / self.dt
        self.diagonal = self.w.diagonal()
        self.w_nn = self.diagonal[0::2].mean()  # the mean of W's normal diagonal

    def error(self, r):
        """|R - R_ref| / |R_ref|, the per-step error of docs/step-error.md."""
        return np.linalg.norm(r - self.reference) / np.linalg.norm(self.reference)

    def natural_map(self, r):
        """R', R'_n = max(0, R_n - u_n / w_nn), R'_t = clamp(R_t - u_t / w_tt, -mu R'_n, mu R'_n):
        R itself exactly where R and u meet the contact laws."""
        u = self.w @ r + self.q
        n = np.maximum(0.0, r[0::2] - u[0::2] / self.diagonal[0::2])
        t = np.clip(r[1::2] - u[1::2] / self.diagonal[1::2], -self.mu * n, self.mu * n)
        return np.stack([n, t], 1).ravel()

    def natural_map_distance(self, r):
        """|R - R'| (natural_map): zero exactly where R and u meet the contact laws."""
        return np.linalg.norm(r - self.natural_map(r))


class Sample:
    def __init__(self, stem):
        self.length_x, self.y_bottom, self.y_top = sample_header(stem)[:3]
        contacts = np.loadtxt(stem + "_contacts.txt", comments="#", ndmin=2)
        bodies = np.loadtxt(stem + "_bodies.txt", comments="#", ndmin=2)
        self.c = contacts[contacts[:, REFERENCE_N] > 0.0]  # force-carrying in the reference
        self.bodies = bodies
        self.error = np.stack([self.c[:, TESTED_N] - self.c[:, REFERENCE_N],
                               self.c[:, TESTED_T] - self.c[:, REFERENCE_T]], 1).ravel()
        self.reference = self.c[:, [REFERENCE_N, REFERENCE_T]].ravel()
        self.a = self.operator()
        self.keys = {(int(r[BODY_A]), int(r[BODY_B])): k for k, r in enumerate(self.c)}
        self._largest = None

    def operator(self):
        """A = M^-1/2 H^T: column 2k the normal impulse of contact k, 2k + 1 its tangential one."""
        scale = sp.diags(np.sqrt(self.bodies[:, INV_MASS].ravel()))
        return (scale @ contact_jacobian(self.c, self.bodies).T).tocsr()

    def grid_space(self, cell, kind):
        """The stress or scale space on a grid of cell x cell hats (columns never empty)."""
        c, m = self.c, len(self.c)
        a = c[:, BODY_A].astype(int)
        n = c[:, [NX, NY]]
        t = np.stack([-n[:, 1], n[:, 0]], 1)
        x = (self.bodies[a, 0] + c[:, ARM_X]) % self.length_x
        y = np.clip(self.bodies[a, 1] + c[:, ARM_Y] - self.y_bottom, 0.0, None)
        height = self.y_top - self.y_bottom
        cells_x = max(1, round(self.length_x / cell))
        cells_y = max(1, round(height / cell))
        fx = x / (self.length_x / cells_x)
        ix = np.floor(fx).astype(int)
        fx -= ix
        fy = np.clip(y / (height / cells_y), 0.0, cells_y - 1e-12)
        iy = np.floor(fy).astype(int)
        fy -= iy
        corners = [(ix % cells_x, 1 - fx), ((ix + 1) % cells_x, fx)]
        levels = [(iy, 1 - fy), (iy + 1, fy)]
        if kind == "stress":
            branch = np.abs(c[:, LEVER_A]) + np.abs(c[:, LEVER_B])
            units = [np.array([[1, 0], [0, 0]]), np.array([[0, 0], [0, 1]]),
                     np.array([[0, 1], [1, 0]])]
            patterns = []
            for e in units:
                force = branch[:, None] * (n @ e.T)  # E l with l = |l| n
                patterns.append(np.stack([np.sum(force * n, 1), np.sum(force * t, 1)], 1))
        else:
            patterns = [c[:, [REFERENCE_N, REFERENCE_T]]]
        rows, cols, vals = [], [], []
        for node_x, wx in corners:
            for node_y, wy in levels:
                node = node_y * cells_x + node_x
                for q, pattern in enumerate(patterns):
                    for d in range(2):
                        rows.append(2 * np.arange(m) + d)
                        cols.append(node * len(patterns) + q)
                        vals.append(wx * wy * pattern[:, d])
        columns = cells_x * (cells_y + 1) * len(patterns)
        p = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                          shape=(2 * m, columns)).toarray()
        return p[:, np.abs(p).sum(0) > 0.0]

    def left_after(self, p):
        """"galerkin / span v velocities": |e - P y| / |e| with y the Galerkin (W-orthogonal)
        projection's coefficients, and with y the orthogonal projection's; |A (e - P y)| / |A e|
        with the Galerkin y."""
        norm = np.linalg.norm(self.error)
        # The Galerkin system restricted to the directions that W does not treat as its null
        # space (singular values of A P below NULL_LEVEL^(1/2) of A's largest): a coarse solve
        # cannot find e's components along self-stresses, nor divide by round-off.
        u, sigma, vt = np.linalg.svd(self.a @ p, full_matrices=False)
        keep = sigma > np.sqrt(NULL_LEVEL) * self.largest_singular_value()
        y = vt[keep].T @ ((u[:, keep].T @ (self.a @ self.error)) / sigma[keep])
        z, *_ = np.linalg.lstsq(p, self.error, rcond=1e-12)
        velocity = self.a @ self.error
        velocity_left = np.linalg.norm(velocity - self.a @ (p @ y)) / np.linalg.norm(velocity)
        return (f"{np.linalg.norm(self.error - p @ y) / norm:.3f} / "
                f"{np.linalg.norm(self.error - p @ z) / norm:.3f} v {velocity_left:.3f}")

    def largest_singular_value(self):
        if self._largest is None:
            self._largest = sla.svds(self.a, k=1, return_singular_vectors=False)[0]
        return self._largest

    def eigen(self):
        """W's eigenvalues (ascending) and eigenvectors."""
        return np.linalg.eigh((self.a.T @ self.a).toarray())


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder")
    parser.add_argument("--cells", default="8,4,2", help="grid cells [d], comma-separated")
    parser.add_argument("--lowest", default="", help="eigenvector counts, comma-separated")
    parser.add_argument("--stale", action="store_true")
    args = parser.parse_args()
    if args.stale and not args.lowest:
        parser.error("--stale needs --lowest")
    cells = [float(v) for v in args.cells.split(",") if v]
    lowest = [int(v) for v in args.lowest.split(",") if v]
    first = None
    for stem in sample_stems(args.folder):
        s = Sample(stem)
        line = [f"{stem.split('/')[-1]}: {len(s.c)} force-carrying, "
                f"|e| / |R| {np.linalg.norm(s.error) / np.linalg.norm(s.reference):.2e}; "
                f"left (galerkin / span v velocities):"]
        for cell in cells:
            for kind in ("stress", "scale"):
                p = s.grid_space(cell, kind)
                line.append(f"{kind} {cell:g} ({p.shape[1]}) {s.left_after(p)}")
        if lowest:
            values, vectors = s.eigen()
            null = vectors[:, values < NULL_LEVEL * values[-1]]
            in_null = np.linalg.norm(null.T @ s.error) / np.linalg.norm(s.error)
            line.append(f"null space ({null.shape[1]}) holds {in_null:.3f}")
            for k in lowest:
                line.append(f"lowest {k} {s.left_after(vectors[:, :k])}")
            if args.stale and first is None:
                first = (s, vectors)
            elif args.stale:
                s0, v0 = first
                for k in (min(k, v0.shape[1]) for k in lowest):
                    p = np.zeros((len(s.error), k))
                    for key, j in s.keys.items():
                        if key in s0.keys:
                            i = s0.keys[key]
                            p[2 * j:2 * j + 2] = v0[2 * i:2 * i + 2, :k]
                    line.append(f"first sample's lowest {k} {s.left_after(p)}")
        print(line[0] + " " + ", ".join(line[1:]), flush=True)


if __name__ == "__main__":
    main()
