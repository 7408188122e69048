import json,statistics,glob
def key(r): return (r['scene'], r['tracer'], r['ray_kind'])
rounds=sorted({int(f.split('-')[-1].split('.')[0]) for f in glob.glob('bench-head-*.json')})
runs={}
for b in ['head','tri']:
    for rd in rounds:
        for r in json.load(open(f'bench-{b}-{rd}.json'))['records']:
            if r.get('perf_mrays_s') is None: continue
            runs.setdefault((b,rd),{})[key(r)]=r
print("| scene | rays | nodes only, Mrays/s (median) | nodes and triangles / nodes only (median, range) | N_IT |")
print("|---|---|---:|---:|---:|")
for k in runs[('head',rounds[0])]:
    if k[1]!='gpu-single': continue
    rat=[runs[('tri',rd)][k]['perf_mrays_s']/runs[('head',rd)][k]['perf_mrays_s'] for rd in rounds]
    med=statistics.median(runs[('head',rd)][k]['perf_mrays_s'] for rd in rounds)
    print(f"| {k[0]} | {k[2]} | {med:.2f} | {statistics.median(rat):.3f} ({min(rat):.2f}-{max(rat):.2f}) | {runs[('head',rounds[0])][k]['n_it_tests_per_ray']:.1f} |")
