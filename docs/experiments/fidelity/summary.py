import json, statistics as st, sys
rows = json.load(open(sys.argv[1]))["rows"]
def med(xs): xs=[x for x in xs if x==x]; return st.median(xs) if xs else float('nan')
keys=[]
for r in rows:
    k=(r['workload'],r['variant'],r['transport'],r['link'],r['nodes'])
    if k not in keys: keys.append(k)
print("| workload | variant | transport | link | nodes | compute per node, cpu (median ratio) | phase 2, wall | frame, wall | frame measured (s) |")
print("|---|---|---|---|---|---|---|---|---|")
for k in sorted(keys, key=lambda k:(k[0],k[1],k[3],k[2],k[4])):
    g=[r for r in rows if (r['workload'],r['variant'],r['transport'],r['link'],r['nodes'])==k]
    ratio=lambda r: r['modelled_s']/r['measured_s'] if r['measured_s']>0 else float('nan')
    comp=med([ratio(r) for r in g if r['phase'] in ('scan','render') and r['node'] is not None and r['measured_s']>0])
    p2=[ratio(r) for r in g if r['phase'].startswith('phase2') and r['node'] is None]
    fr=[r for r in g if r['phase']=='frame']
    p2s = f"{p2[0]:.2f}" + (" (master only)" if any(r['phase']=='phase2-master-only' for r in g) else "") if p2 else "-"
    print(f"| {k[0]} | {k[1]} | {k[2]} | {k[3]} | {k[4]} | {comp:.2f} | {p2s} | {ratio(fr[0]):.2f} | {fr[0]['measured_s']:.4f} |")
