"""What machine a peer benchmark ran on: its figures depend on it (Mitsuba's LLVM variants
vectorise to the widest SIMD the CPU has; aleph's BVH packs are at most eight wide)."""
import os


def cpu_description():
    """This machine's CPU model and widest SIMD (the vectorised variant's lane count follows it)."""
    model, flags = "unknown CPU", set()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name") and model == "unknown CPU":
                    model = line.split(":", 1)[1].strip()
                elif line.startswith("flags") and not flags:
                    flags = set(line.split(":", 1)[1].split())
    except OSError:
        pass
    simd = "AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags else "SSE/NEON"
    return f"{model}, {os.cpu_count()} logical CPUs, widest SIMD {simd}"
