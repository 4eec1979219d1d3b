"""Coverage of three ± estimators on a self-check suite's strong withheld cases.

Reads OUT/cases.csv (pooled relative errors and errors in σ) and each case's
diagnosis.json (first fit, refits). The truth t comes from the pooled value v, its stated ±
s, |v−t| = z·s and |v−t|/|t| = rel (both from cases.csv)."""
import csv, json, math, sys, os

out = sys.argv[1]
K = int(sys.argv[2]) if len(sys.argv) > 2 else 3
rows = list(csv.DictReader(open(os.path.join(out, 'cases.csv'))))
res = {'old': [], 'pooled': [], 'pooled+Ks2': []}
errs = {'first': [], 'pooled': []}
for r in rows:
    if not r['case'].startswith('withheld') or not r['param_rel_errors']:
        continue
    d = json.load(open(os.path.join(out, 'cases', r['case'], 'diagnosis', 'diagnosis.json')))
    b = d['ranking'][0]
    eff = r['case'].split('-')[1]
    rels = [float(x) for x in r['param_rel_errors'].split()]
    zs = [float(x) for x in r['param_errors_in_sd'].split()]
    rf = b.get('refit', {})
    if rf.get('status') != 'done':
        print('no refit', r['case']); continue
    keys = [k for k in b['params'] if b['params_std'][k] is not None]
    # the scored parameters are the withheld effect's finite-σ ones, in order
    keys = [k for k in keys if (len(b['params']) == len([1 for _ in b['params']]) and ('.' not in k or k.startswith(eff + '.')))]
    if len(keys) != len(rels):
        print('skip', r['case'], keys, rels); continue
    for k, rel, z in zip(keys, rels, zs):
        v, s = b['params'][k], b['params_std'][k]
        if rel == 0:
            t = v
        else:
            a = abs(v - t) if False else z * s
            cands = [v - a, v + a]
            t = min(cands, key=lambda c: abs(abs(v - c) / abs(c) - rel) if c != 0 else 9e9)
        v1, s1 = rf['params_first_fit'][k], rf['params_std_first_fit'][k]
        fits = [(v1, s1)] + [(x['params'][k], x['params_std'][k]) for x in rf['runs'] if x['params_std'].get(k) is not None]
        v2 = fits[1][0]
        old = math.hypot(s1, (v1 - v2) / math.sqrt(2))
        n = len(fits)
        m = sum(f[0] for f in fits) / n
        s2 = sum((f[0] - m) ** 2 for f in fits) / (n - 1)
        cv = sum(f[1] ** 2 for f in fits) / n
        pooled = math.sqrt(cv + s2 / n)
        data = math.sqrt(max(cv, K * s2) + s2 / n)
        res['old'].append(abs(v1 - t) / old)
        res['pooled'].append(abs(m - t) / pooled)
        res['pooled+Ks2'].append(abs(m - t) / data)
        errs['first'].append(abs(v1 - t) / abs(t) if t else 0)
        errs['pooled'].append(abs(m - t) / abs(t) if t else 0)
        print(f"{r['case']:40s} {k:22s} t={t:.5g} first={v1:.5g} pooled={m:.5g}±{pooled:.3g} "
              f"z_old={abs(v1-t)/old:.2f} z_pool={abs(m-t)/pooled:.2f} z_K={abs(m-t)/data:.2f} fits={[round(f[0],5) for f in fits]}")
med = lambda x: sorted(x)[len(x) // 2] if len(x) % 2 else sum(sorted(x)[len(x)//2-1:len(x)//2+1]) / 2
for k, z in res.items():
    print(f"{k:12s} within 2σ {sum(1 for x in z if x <= 2)}/{len(z)}, within 1σ {sum(1 for x in z if x <= 1)}/{len(z)}, median |z| {med(z):.2f}")
for k, e in errs.items():
    print(f"median relative error, {k}: {100*med(e):.2f} %  mean {100*sum(e)/len(e):.2f} %")
