# The best candidate's 95 % interval of each self-check case, recomputed from its
# diagnosis.json as `diagnose::fit_noise::interval95` states it (runs written before
# `params_ci95` existed carry everything it needs): the refits' spread s²/n on n − 1 degrees
# of freedom, the footages' spread² where they widened the ± (plus the bias's spread²/B where
# it was taken off) on B − 1, Welch–Satterthwaite's ν,
# k = t₀.₉₇₅ on ⌊ν⌋; then whether the case's truth lies within k·σ (the error in σ from
# cases.csv), beside the ±1.96σ and ±2σ a normal reading would take.
# Usage: python3 intervals.py SUITE_DIR [SUITE_DIR…] (folders of `geneva diagnose-selfcheck --out`).
import csv, json, math, os, sys

T975 = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179,
        2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064,
        2.060, 2.056, 2.052, 2.048, 2.045, 2.042]

def t975(dof):
    if dof <= 30:
        return T975[max(dof, 1) - 1]
    z = 1.959964
    return z + (z**3 + z) / (4 * dof) + (5 * z**5 + 16 * z**3 + 3 * z) / (96 * dof * dof)

def fits_of(r, k):
    ref = r.get('refit', {})
    if ref.get('status', 'done') != 'done' or 'runs' not in ref:
        return []
    first = (ref['params_first_fit'][k], ref['params_std_first_fit'][k])
    runs = [(x['params'][k], x['params_std'][k]) for x in ref['runs']]
    ok = lambda f: f[0] is not None and f[1] is not None
    if not ok(first):
        return []
    return [first] + [f for f in runs if ok(f)]

# diagnosis.json keys its parameters alphabetically; cases.csv lists the errors in the
# effect's own parameter order (`Effect::params`), which differs for these.
ORDER = {'frame_timing': ['jitter_s', 'first_interval_s', 'rate_error_ppm', 'drop_probability',
                          'pair_alternation_s']}

total = {'t': [0, 0], '1.96': [0, 0], '2': [0, 0]}
for root in sys.argv[1:]:
    for u in csv.DictReader(open(os.path.join(root, 'cases.csv'))):
        d = json.load(open(os.path.join(root, 'cases', u['case'], 'diagnosis', 'diagnosis.json')))
        if not d['ranking']:
            continue
        r = d['ranking'][0]
        zs = [float(x) for x in u['param_errors_in_sd'].split()]
        keys = [k for k in ORDER.get(r['effect'], list(r['params_std']))
                if r['params_std'][k] is not None]
        # A pair keys its parameters `effect.name`; cases.csv scores the withheld effect's.
        withheld = u['expectation'].split()[1] if u['expectation'].startswith('withheld') else None
        if len(r.get('effects', [])) > 1 and withheld:
            keys = [k for k in keys if k.startswith(withheld + '.')]
        print(f"{root.rstrip('/').split('/')[-1]}/{u['case']}: {d['verdict']}, best {r['effect']}")
        for k, z in zip(keys, zs):
            sd = r['params_std'][k]
            parts = []
            fits = fits_of(r, k)
            if len(fits) >= 2:
                n = len(fits)
                mean = sum(f[0] for f in fits) / n
                s2 = sum((f[0] - mean) ** 2 for f in fits) / (n - 1)
                parts.append((s2 / n, n - 1))
            b = r.get('bootstrap', {})
            if b.get('status') == 'done' and b['params_std_before'].get(k) is not None:
                nb = sum(1 for f in b['footages'] if f['params'].get(k) is not None)
                bias_var = (b['bias_std'][k] ** 2
                            if b.get('bias_corrected', {}).get(k) else 0.0)
                widened = sd * sd - b['params_std_before'][k] ** 2 - bias_var > 1e-9 * sd * sd
                part = (b['footage_std'][k] ** 2 if widened else 0.0) + bias_var
                if part > 0:
                    parts.append((part, nb - 1))
            den = sum(u2 * u2 / dof for u2, dof in parts if u2 > 0)
            nu = (sd**4) / den if den > 0 else math.inf
            kf = t975(max(1, math.floor(nu * (1 + 1e-9)))) if math.isfinite(nu) else 1.959964
            inside = {'t': z <= kf, '1.96': z <= 1.959964, '2': z <= 2.0}
            for name, v in inside.items():
                total[name][0] += v
                total[name][1] += 1
            print(f"  {k}: ± {sd:.4g}, error {z:.2f} σ; parts {[(f'{a:.3g}', b_) for a, b_ in parts]} "
                  f"ν = {nu if nu < 1e6 else math.inf:.1f}, k = {kf:.3f}: {'inside' if inside['t'] else 'OUTSIDE'} "
                  f"(±1.96σ: {'inside' if inside['1.96'] else 'outside'})")
for name, (k, n) in total.items():
    print(f"within {'the t interval' if name == 't' else '±' + name + 'σ'}: {k}/{n}")
