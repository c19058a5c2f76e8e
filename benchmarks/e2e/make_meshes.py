import sys
import os
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from pathlib import Path
import bench_speed
print(bench_speed._write_inputs("1M", "tri", 1_000_000, Path(os.environ.get("E2E_DIR", "/tmp/io_b"))))
