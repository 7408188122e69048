import json,sys,statistics,glob
rounds=sorted({int(f.split('-')[-1].split('.')[0]) for f in glob.glob('bench-storage-*.json')})
def key(r): return (r['scene'], r['tracer'], r.get('packet'), r['ray_kind'])
runs={}
for m in ['storage','texel']:
    for rd in rounds:
        for r in json.load(open(f'bench-{m}-{rd}.json'))['records']:
            if r.get('perf_mrays_s') is None: continue
            runs.setdefault((m,rd),{})[key(r)]=r
print("| scene | tracer | rays | storage Mrays/s, median | texel / storage, each round | the same over the 8-wide kernel of its process |")
print("|---|---|---|---:|---:|---:|")
for k in runs[('storage',1)]:
    if k[1]=='gpu-cwbvh': continue
    ctrl=(k[0],'gpu-cwbvh',{'primary':'8x16','shadow':'32x4'}[k[3]],k[3])
    direct=[runs[('texel',rd)][k]['perf_mrays_s']/runs[('storage',rd)][k]['perf_mrays_s'] for rd in rounds]
    norm=[(runs[('texel',rd)][k]['perf_mrays_s']/runs[('texel',rd)][ctrl]['perf_mrays_s'])/(runs[('storage',rd)][k]['perf_mrays_s']/runs[('storage',rd)][ctrl]['perf_mrays_s']) for rd in rounds]
    med=statistics.median(runs[('storage',rd)][k]['perf_mrays_s'] for rd in rounds)
    same=all(runs[('texel',rd)][k]['n_tr_nodes_per_ray']==runs[('storage',rd)][k]['n_tr_nodes_per_ray'] for rd in rounds)
    assert same
    print(f"| {k[0]} | {k[1]} {k[2]} | {k[3]} | {med:.2f} | {min(direct):.2f}-{max(direct):.2f} (median {statistics.median(direct):.2f}) | {min(norm):.2f}-{max(norm):.2f} (median {statistics.median(norm):.2f}) |")
