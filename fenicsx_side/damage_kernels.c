/* The FE damage law's per-cell loops (fenicsx_side.damage_law, fenicsx_side.damaged): one pass
 * over the cells each, where numpy needed a pass per operation. The formulas and their
 * references are in damage_law.py's docstrings; this file only computes them.
 *
 * Symmetric tensors are six components, component-major over n cells: v[k * n + c], k in
 * xx, yy, zz, yz, xz, xy (tensor components, not engineering shears).
 * Compiled with -ffp-contract=off and no -march (fenicsx_side/kernels.py): no fused
 * multiply-add, so the same digits on any machine with the same compiler and C library. */
#include <math.h>
#include <stdint.h>

#define SQRT3 1.7320508075688772
#define NEAR_ROOT 1e-3   /* eigenvalues this close (× the largest) go to Jacobi's method */

static double contract6(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + 2 * (a[3] * b[3] + a[4] * b[4] + a[5] * b[5]);
}

/* The trigonometric solution of the characteristic cubic (Smith, CACM 4, 1961, 168): the
 * eigenvalues are q + 2 p cos(φ + 2πk/3), q the mean, p = |dev v| / √6 (so q − 2p ≤ λ ≤ q + 2p),
 * φ = acos(r) / 3, r = det((v − q 1) / p) / 2. The loops run in blocks of BLOCK cells, one
 * pass for what comes before the trigonometry, one for it, one after: each pass's iterations
 * are independent, so that the processor overlaps them (one pass per cell would wait on the
 * chain sqrt → acos → cos → projector, 3x slower). */
#define BLOCK 64

static double cubic_r(const double *v, double q, double p)
{
    double b[6] = {v[0] - q, v[1] - q, v[2] - q, v[3], v[4], v[5]};
    double s = p > 0 ? p : 1.0;       /* dividing keeps r = ±1 exact for a diagonal v */
    double xx = b[0] / s, yy = b[1] / s, zz = b[2] / s, yz = b[3] / s, xz = b[4] / s, xy = b[5] / s;
    double r = (xx * (yy * zz - yz * yz) - xy * (xy * zz - yz * xz) + xz * (xy * yz - yy * xz)) / 2;
    return r < -1 ? -1 : (r > 1 ? 1 : r);
}

/* q and p² of one tensor. */
static double mean_and_spread(const double *v, double *p2)
{
    double q = (v[0] + v[1] + v[2]) / 3;
    double b[6] = {v[0] - q, v[1] - q, v[2] - q, v[3], v[4], v[5]};
    *p2 = contract6(b, b) / 6;
    return q;
}

/* Cyclic Jacobi on one symmetric 3×3 matrix a (overwritten): eigenvalues on its diagonal,
 * eigenvectors in the columns of e. Backward stable whatever the eigenvalues' spacing. */
static void jacobi3(double a[3][3], double e[3][3])
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) e[i][j] = i == j;
    for (int sweep = 0; sweep < 50; sweep++) {
        double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        double diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if (off <= 1e-36 * (diag + off)) return;          /* below rounding */
        for (int p = 0; p < 2; p++)
            for (int q = p + 1; q < 3; q++) {
                if (a[p][q] == 0) continue;
                double theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
                double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1));
                double c = 1 / sqrt(t * t + 1), s = t * c;
                for (int k = 0; k < 3; k++) {          /* a ← a J (columns p, q) */
                    double akp = a[k][p], akq = a[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for (int k = 0; k < 3; k++) {          /* a ← Jᵀ a (rows p, q) */
                    double apk = a[p][k], aqk = a[q][k];
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                a[p][q] = a[q][p] = 0;
                for (int k = 0; k < 3; k++) {          /* e ← e J */
                    double ekp = e[k][p], ekq = e[k][q];
                    e[k][p] = c * ekp - s * ekq;
                    e[k][q] = s * ekp + c * ekq;
                }
            }
    }
}

static const int PAIR_A[6] = {0, 1, 2, 1, 0, 0}, PAIR_B[6] = {0, 1, 2, 2, 2, 1};

/* Σ ⟨λ_i⟩ n_i⊗n_i of one tensor v of mixed or unknown sign, its q, p and cos φ, sin φ given:
 * Sylvester's projector of the one eigenvalue whose sign differs; Jacobi where two eigenvalues
 * are close and the signs are not all one (damage_law.positive_part explains the accuracy). */
static void positive_part3(const double *v, double q, double p, double c, double s, double *out)
{
    double l[3] = {q + 2 * p * c, 0, q - p * (c + SQRT3 * s)};   /* cos(φ + 2π/3) */
    l[1] = 3 * q - l[0] - l[2];
    double big = fmax(fabs(l[0]), fmax(fabs(l[1]), fabs(l[2])));
    double tol = NEAR_ROOT * big;
    int near = fmin(l[0] - l[1], l[1] - l[2]) <= tol;
    for (int k = 0; k < 6; k++) out[k] = 0;
    if (l[2] >= 0) {
        for (int k = 0; k < 6; k++) out[k] = v[k];
        return;
    }
    if (near && l[0] > -tol && l[2] < tol) {
        double a[3][3], e[3][3];
        for (int k = 0; k < 6; k++) a[PAIR_A[k]][PAIR_B[k]] = a[PAIR_B[k]][PAIR_A[k]] = v[k];
        jacobi3(a, e);
        for (int i = 0; i < 3; i++) {
            double w = a[i][i];
            if (w <= 0) continue;
            for (int k = 0; k < 6; k++) out[k] += w * e[PAIR_A[k]][i] * e[PAIR_B[k]][i];
        }
        return;
    }
    int k0;
    if (!near && l[0] > 0 && l[1] <= 0) k0 = 0;
    else if (!near && l[1] > 0 && l[2] < 0) k0 = 2;
    else return;                                    /* all ≤ 0 */
    int i = k0 == 0 ? 1 : 0, j = k0 == 0 ? 2 : 1;
    double xx = v[0], yy = v[1], zz = v[2], yz = v[3], xz = v[4], xy = v[5];
    double sq[6] = {xx * xx + xy * xy + xz * xz, xy * xy + yy * yy + yz * yz,
                    xz * xz + yz * yz + zz * zz, xy * xz + yy * yz + yz * zz,
                    xx * xz + xy * yz + xz * zz, xx * xy + xy * yy + xz * yz};
    double f = l[k0] / ((l[k0] - l[i]) * (l[k0] - l[j]));
    for (int k = 0; k < 6; k++) {
        double product = sq[k] - (l[i] + l[j]) * v[k] + (k < 3 ? l[i] * l[j] : 0.0);
        double part = f * product;
        out[k] = k0 == 0 ? part : v[k] - part;
    }
}

/* The positive parts out (6, n) of tensors v (6, n): where q ± 2p bound the eigenvalues to one
 * sign, v or 0 without the cubic. */
void positive_part(int64_t n, const double *v, double *out)
{
    for (int64_t start = 0; start < n; start += BLOCK) {
        int64_t end = start + BLOCK < n ? start + BLOCK : n, mixed[BLOCK];
        double q[BLOCK], p[BLOCK], c[BLOCK], s[BLOCK];
        int count = 0;
        for (int64_t i = start; i < end; i++) {
            double t[6], p2;
            for (int k = 0; k < 6; k++) t[k] = v[k * n + i];
            double mean = mean_and_spread(t, &p2);
            if (mean * mean >= 4 * p2) {
                for (int k = 0; k < 6; k++) out[k * n + i] = mean >= 0 ? t[k] : 0.0;
                continue;
            }
            q[count] = mean;
            p[count] = sqrt(p2);
            c[count] = cubic_r(t, mean, p[count]);
            mixed[count++] = i;
        }
        for (int k = 0; k < count; k++) {
            double phi = acos(c[k]) / 3;
            c[k] = cos(phi);
            s[k] = sin(phi);
        }
        for (int k = 0; k < count; k++) {
            int64_t i = mixed[k];
            double t[6], o[6];
            for (int a = 0; a < 6; a++) t[a] = v[a * n + i];
            positive_part3(t, q[k], p[k], c[k], s[k], o);
            for (int a = 0; a < 6; a++) out[a * n + i] = o[a];
        }
    }
}

/* The cells' mean strains ε_ab = ½ Σ_i (u_ia g_ib + u_ib g_ia), g the nv mean gradients of
 * each cell's shape functions (n, nv, 3), u_ia = u[3 node + a]. */
void cell_strains(int64_t n, int64_t nv, const int64_t *nodes, const double *grad,
                  const double *u, double *eps)
{
    for (int64_t c = 0; c < n; c++) {
        double e[6] = {0, 0, 0, 0, 0, 0};
        for (int64_t i = 0; i < nv; i++) {
            const double *g = grad + 3 * (c * nv + i), *x = u + 3 * nodes[c * nv + i];
            e[0] += g[0] * x[0];
            e[1] += g[1] * x[1];
            e[2] += g[2] * x[2];
            e[3] += 0.5 * (g[2] * x[1] + g[1] * x[2]);
            e[4] += 0.5 * (g[2] * x[0] + g[0] * x[2]);
            e[5] += 0.5 * (g[1] * x[0] + g[0] * x[1]);
        }
        for (int k = 0; k < 6; k++) eps[k * n + c] = e[k];
    }
}

/* ε_t = ⟨λ_e tr ε + ε₁ / (1 + ν)⟩ (λ_e = λ / E) where the bound ε₁ ≤ tr ε / 3 + 2p lets it
 * pass its floor, max(floor[c], floor0); elsewhere that bound (≥ 0), which stays below it. */
static void tension_pass(int64_t n, const double *eps, const double *floor, double floor0,
                         double lam_e, double nu, double *out)
{
    for (int64_t start = 0; start < n; start += BLOCK) {
        int64_t end = start + BLOCK < n ? start + BLOCK : n, past[BLOCK];
        double q[BLOCK], p[BLOCK], c[BLOCK];
        int count = 0;
        for (int64_t i = start; i < end; i++) {
            double t[6], p2;
            for (int k = 0; k < 6; k++) t[k] = eps[k * n + i];
            double mean = mean_and_spread(t, &p2);
            double bound = lam_e * 3 * mean + (mean + 2 * sqrt(p2)) / (1 + nu);
            out[i] = bound > 0 ? bound : 0;
            if (bound > fmax(floor[i], floor0)) {
                q[count] = mean;
                p[count] = sqrt(p2);
                c[count] = cubic_r(t, mean, p[count]);
                past[count++] = i;
            }
        }
        for (int k = 0; k < count; k++) c[k] = cos(acos(c[k]) / 3);
        for (int k = 0; k < count; k++) {
            double value = lam_e * 3 * q[k] + (q[k] + 2 * p[k] * c[k]) / (1 + nu);
            out[past[k]] = value > 0 ? value : 0;
        }
    }
}

void tension_strain(int64_t n, const double *eps, const double *floor, double lam_e,
                    double nu, double *out)
{
    tension_pass(n, eps, floor, -INFINITY, lam_e, nu, out);
}

/* de Vree's ε_c of one strain where tr ε < 0, else 0 (k = fc / ft). */
static double compression3(const double *t, double k, double nu)
{
    double i1 = t[0] + t[1] + t[2];
    if (!(i1 < 0)) return 0.0;
    double j2 = 0.5 * (contract6(t, t) - i1 * i1 / 3);
    double a = (k - 1) * i1 / (1 - 2 * nu);
    return (a + sqrt(a * a + 12 * k * (j2 > 0 ? j2 : 0) / ((1 + nu) * (1 + nu)))) / (2 * k);
}

void compression_strain(int64_t n, const double *eps, double k, double nu, double *out)
{
    for (int64_t c = 0; c < n; c++) {
        double t[6];
        for (int a = 0; a < 6; a++) t[a] = eps[a * n + c];
        out[c] = compression3(t, k, nu);
    }
}

/* D(κ) = 1 − (κ₀ / κ) exp(−(κ − κ₀) / ε_f) above κ₀, else 0. */
static double damage1(double kappa, double eps_f, double kappa0)
{
    return kappa > kappa0 ? 1.0 - (kappa0 / kappa) * exp(-(kappa - kappa0) / eps_f) : 0.0;
}

void damage(int64_t n, const double *kappa, const double *eps_f, double kappa0, double *out)
{
    for (int64_t c = 0; c < n; c++) out[c] = damage1(kappa[c], eps_f[c], kappa0);
}

/* One step's screening of all n cells of mean strains eps (6, n): the equivalent strains, and
 * the cells where either passes its history (max(κ, κ₀)): their histories raised in place, the
 * cells listed in grow (ascending), flags 1 (tension), 2 (compression) or 3; returns their
 * count. eq: scratch (n). */
int64_t screen(int64_t n, const double *eps, double *kappa, double *kappa_c, double kappa0,
               double lam_e, double nu, double k, double *eq, int64_t *grow, int8_t *flags)
{
    tension_pass(n, eps, kappa, kappa0, lam_e, nu, eq);
    int64_t count = 0;
    for (int64_t c = 0; c < n; c++) {
        double t[6];
        for (int a = 0; a < 6; a++) t[a] = eps[a * n + c];
        double ec = compression3(t, k, nu);
        int bits = (eq[c] > fmax(kappa[c], kappa0)) | (ec > fmax(kappa_c[c], kappa0)) << 1;
        if (!bits) continue;
        if (bits & 1) kappa[c] = eq[c];
        if (bits & 2) kappa_c[c] = ec;
        grow[count] = c;
        flags[count++] = (int8_t)bits;
    }
    return count;
}

/* The k growing cells' damages from their histories, in place; step (3, k): the increments of
 * D_t, D_c and D = max(D_t, D_c). */
void grow_damage(int64_t k, const int64_t *grow, const double *kappa, const double *eps_f,
                 const double *kappa_c, const double *eps_fc, double kappa0, double *d_t,
                 double *d_c, double *d, double *step)
{
    for (int64_t i = 0; i < k; i++) {
        int64_t c = grow[i];
        double nt = damage1(kappa[c], eps_f[c], kappa0), nc = damage1(kappa_c[c], eps_fc[c], kappa0);
        double nd = fmax(nt, nc);
        step[i] = nt - d_t[c];
        step[k + i] = nc - d_c[c];
        step[2 * k + i] = nd - d[c];
        d_t[c] = nt;
        d_c[c] = nc;
        d[c] = nd;
    }
}

/* The damaged cells' split: for cell c = hit[j] of strain w (6, m), σ̄ = C : w (E, ν) into sig,
 * its positive part into pos (6, m), and the displacements of its dofs into u_c (m, dofs). */
void split_cells(int64_t m, int64_t dofs, const int64_t *hit, const int64_t *cell_dofs,
                 const double *u, const double *w, double young, double nu, double *sig,
                 double *pos, double *u_c)
{
    double shear = young / (1 + nu), lame = young * nu / ((1 + nu) * (1 - 2 * nu));
    for (int64_t j = 0; j < m; j++) {
        double tr = w[j] + w[m + j] + w[2 * m + j];
        for (int k = 0; k < 6; k++) sig[k * m + j] = shear * w[k * m + j] + (k < 3 ? lame * tr : 0.0);
        const int64_t *dof = cell_dofs + dofs * hit[j];
        for (int64_t a = 0; a < dofs; a++) u_c[j * dofs + a] = u[dof[a]];
    }
    positive_part(m, sig, pos);
}

/* The energy the damage increments dissipate: Σ over the k growing cells c = grow[i] whose
 * damage moved, at place j = at[i] of the split (w, sig, pos: (6, m); u_c, rest: (m, dofs)), of
 * ½ ΔD u_c·K_rest u_c + V_c (½ σ̄⁺:w ΔD_t + ½ σ̄⁻:w ΔD_c); each cell's term also added to
 * cells[c] (one per cell of the model). */
double dissipation(int64_t k, int64_t m, int64_t dofs, const int64_t *grow, const int64_t *at,
                   const double *step, const double *step_t, const double *step_c,
                   const double *u_c, const double *rest, const double *w, const double *sig,
                   const double *pos, const double *volume, double *cells)
{
    double total = 0;
    for (int64_t i = 0; i < k; i++) {
        if (step[i] == 0 && step_t[i] == 0 && step_c[i] == 0) continue;  /* D still 0: not split */
        int64_t j = at[i];
        double ur = 0, yt = 0, yc = 0;
        for (int64_t a = 0; a < dofs; a++) ur += u_c[j * dofs + a] * rest[j * dofs + a];
        for (int q = 0; q < 6; q++) {
            double f = q < 3 ? 0.5 : 1.0, p = pos[q * m + j], e = w[q * m + j];
            yt += f * p * e;
            yc += f * (sig[q * m + j] - p) * e;
        }
        double term = 0.5 * step[i] * ur + volume[grow[i]] * (yt * step_t[i] + yc * step_c[i]);
        cells[grow[i]] += term;
        total += term;
    }
    return total;
}

/* force −= the m damaged cells' lost forces, in their order: for cell c = hit[j],
 * (D_t σ̄⁺ + D_c σ̄⁻)_c · its force operator (6, dofs; shared by its class, or its own) +
 * D_c × rest[j] (its higher-order force K_rest,c u_c, dofs), at its dofs. sig, pos: (6, m). */
void lost_forces(int64_t m, int64_t dofs, const int64_t *hit, const int64_t *cell_dofs,
                 const double *sig, const double *pos, const double *d_t, const double *d_c,
                 const double *d, const double *rest, const int64_t *class_of,
                 const double *class_ops, const int64_t *own_row, const double *own_ops,
                 double *force)
{
    for (int64_t j = 0; j < m; j++) {
        int64_t c = hit[j];
        double s[6];
        for (int k = 0; k < 6; k++) {
            double p = pos[k * m + j];
            s[k] = d_t[c] * p + d_c[c] * (sig[k * m + j] - p);
        }
        const double *op = class_of[c] >= 0 ? class_ops + 6 * dofs * class_of[c]
                                            : own_ops + 6 * dofs * own_row[c];
        for (int64_t a = 0; a < dofs; a++) {
            double lost = d[c] * rest[j * dofs + a];
            for (int k = 0; k < 6; k++) lost += s[k] * op[k * dofs + a];
            force[cell_dofs[c * dofs + a]] -= lost;
        }
    }
}
