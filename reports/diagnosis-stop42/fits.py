# The first-ranked effect of each self-check case, its pooled value and ±, and the spread across
# the cases of one withheld effect. Usage: python3 fits.py SUITE_DIR (the folder of `geneva
# diagnose-selfcheck --out`).
import json, glob, os, statistics as st, sys
root = sys.argv[1]
units = [json.loads(l.split('\t',1)[1]) for l in open(os.path.join(root,'units.log')) if '\t' in l]
man = json.load(open(os.path.join(root,'manifest.json')))['inputs']
by = {}
for u in units:
    name = u['name']; eff = u['expectation']['effect']
    d = json.load(open(os.path.join(root,'cases',name,'diagnosis','diagnosis.json')))
    r = d['ranking'][0]
    by.setdefault(eff, []).append((name, d['verdict'], r['effect'], r['params'], r['params_std'], u['param_rel_errors'], u['param_errors_in_sd'], r['shrink']))
for eff, rows in sorted(by.items()):
    print(f'## {eff}')
    vals = {}
    for name, verdict, best, p, s, rel, zs, shrink in rows:
        print(f'{name}: {verdict}, best {best}, shrink {shrink:.3f}, params {p} ± {s}, rel err {rel}, err/sd {zs}')
        if best == eff:
            for k in p:
                vals.setdefault(k, []).append((p[k], s[k]))
    for k, vs in vals.items():
        v = [a for a,_ in vs]; sd = [b for _,b in vs]
        if len(v) > 1 and any(x is None for x in sd):
            # A parameter the footage does not determine has no finite ± (JSON null).
            print(f'  {k}: n={len(v)} mean {st.mean(v):.4f}, between-footage sd {st.stdev(v):.4f}, stated ± not determined')
        elif len(v) > 1:
            print(f'  {k}: n={len(v)} mean {st.mean(v):.4f}, between-footage sd {st.stdev(v):.4f}, rms stated ± {(sum(x*x for x in sd)/len(sd))**0.5:.4f}, ratio {st.stdev(v)/((sum(x*x for x in sd)/len(sd))**0.5):.2f}')
