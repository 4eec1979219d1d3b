# The best candidate of each self-check case with its fits on footages simulated at its stated
# values (`geneva diagnose --bootstrap`): the value and ± before and after, the footages' values,
# spread and bias, and the error against the case's truth in units of each ±.
# Usage: python3 bootstrap.py SUITE_DIR [SUITE_DIR…] (folders of `geneva diagnose-selfcheck --out`).
import csv, json, os, sys
for root in sys.argv[1:]:
    for u in csv.DictReader(open(os.path.join(root, 'cases.csv'))):
        d = json.load(open(os.path.join(root, 'cases', u['case'], 'diagnosis', 'diagnosis.json')))
        best = [r for r in d['ranking'] if 'bootstrap' in r]
        if not best:
            print(f"{u['case']}: no bootstrap entry ({d['verdict']})")
            continue
        r = best[0]; b = r['bootstrap']
        print(f"{u['case']}: {d['verdict']}, best {r['effect']}, shrink {r['shrink']:.3f}, status {b['status']}")
        if b['status'] != 'done':
            continue
        for k, v in r['params'].items():
            fv = [f['params'][k] for f in b['footages']]
            # A run of the code before the bias test (stop 43's first) wrote no bias fields:
            # its stated value is the value before, and the bias is recomputed here.
            before = b.get('params_before', {}).get(k, v)
            mean = sum(fv) / len(fv)
            sd_before, sd = b['params_std_before'][k], r['params_std'][k]
            fmt = lambda x: 'null' if x is None else f'{x:.5g}'
            bias = b.get('bias', {}).get(k, mean - before)
            extra = (f" (p {fmt(b['bias_p'][k])}, taken off: {b['bias_corrected'][k]})"
                     if 'bias_p' in b else ' (recomputed; this run had no bias test)')
            print(f"  {k}: before {fmt(before)} ± {fmt(sd_before)}; footages {', '.join(fmt(x) for x in fv)}; "
                  f"spread {fmt(b['footage_std'][k])}, bias {fmt(bias)}{extra}; stated {fmt(v)} ± {fmt(sd)}")
        print(f"  self-check (against the truth): relative error {u['param_rel_errors']}, error in stated ± {u['param_errors_in_sd']}")
