import json,sys,statistics as st
d=sys.argv[1]; vs=sys.argv[2].split(','); rounds=int(sys.argv[3])
def rec(v,r):
    return {(x['scene'],x['tracer'],x['ray_kind']):x for x in json.load(open(f'{d}/{v}-{r}.json'))['records']}
R={(v,r):rec(v,r) for v in vs for r in range(1,rounds+1)}
keys=[k for k in R[(vs[0],1)] if k[1]=='gpu-single']
for k in keys:
    line=f"{k[0]:11s} {k[2]:8s} base {st.median(R[(vs[0],r)][k]['perf_mrays_s'] for r in range(1,rounds+1)):6.2f}"
    for v in vs[1:]:
        ratios=[R[(v,r)][k]['perf_mrays_s']/R[(vs[0],r)][k]['perf_mrays_s'] for r in range(1,rounds+1)]
        line+=f" | {v}/base med {st.median(ratios):.3f} [{min(ratios):.3f}-{max(ratios):.3f}] N_TR {R[(v,1)][k]['n_tr_nodes_per_ray']:.2f}/{R[(vs[0],1)][k]['n_tr_nodes_per_ray']:.2f}"
    print(line)
