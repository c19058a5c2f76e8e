import json, sys, time, resource
T0 = (time.perf_counter(), time.process_time())
import meshio
t1 = (time.perf_counter(), time.process_time())
m = meshio.read(sys.argv[1])
t2 = (time.perf_counter(), time.process_time())
meshio.write(sys.argv[2], m, file_format="vtu", compression="zlib")
t3 = (time.perf_counter(), time.process_time())
print(json.dumps({"import": [t1[0]-T0[0], t1[1]-T0[1]], "read": [t2[0]-t1[0], t2[1]-t1[1]], "write": [t3[0]-t2[0], t3[1]-t2[1]],
                  "total": [t3[0]-T0[0], t3[1]-T0[1]], "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss/1024}))
