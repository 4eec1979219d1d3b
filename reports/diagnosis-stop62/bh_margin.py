import json,glob,sys
# BH margin per case: min over ranks i of p_(i)·m/(i·q); significant cells exist iff it is ≤ 1.
for folder in sys.argv[1:]:
    out=[]
    for f in sorted(glob.glob(folder+'/cases/*/diagnosis/diagnosis.json')):
        d=json.load(open(f))
        q=d['thresholds'].get('fdr_q',0.01) if isinstance(d['thresholds'],dict) else 0.01
        ps=sorted(c['p'] for c in d['gap']['cells'] if c['p'] is not None)
        m=len(ps)
        r=min(p*m/((i+1)*q) for i,p in enumerate(ps))
        out.append((r,f.split('/')[-3],d['verdict'],d['gap']['total'],m,q))
    out.sort()
    print(folder, 'cases', len(out), 'verdicts', {v:sum(1 for o in out if o[2]==v) for v in sorted(set(o[2] for o in out))})
    for o in out[:5]: print('  closest: BH ratio %.2f %s %s D0=%.3f cells=%d q=%g'%o)
    rs=sorted(o[0] for o in out); print('  median BH ratio %.2f'%rs[len(rs)//2])
