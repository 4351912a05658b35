#!/usr/bin/env bash
# Run a vibrobar design map as a Slurm job array, then merge the shards.
#
#   scripts/slurm-map.sh            # submits the array and a dependent merge job
#
# Edit the MAP_ARGS below (everything except --shard and --out). Every array task computes the
# grid points i with i mod N = K-1 (round-robin, so each task gets a similar mix of cheap and
# expensive points) and writes maps/map.K.csv + maps/map.K.csv.meta.json. The merge job checks
# that all N shards come from the same job and cover the grid, then writes maps/map.csv (byte-
# identical to a single-machine run), FILE.optimum.csv and the figures.
#
# A task that is killed (time limit, preemption) keeps its finished rows in
# maps/map.K.csv.journal; resubmitting the same array resumes it (--resume is given, and is a
# no-op for a fresh start).
set -euo pipefail

N=${N:-32}                        # number of array tasks (shards)
OUT_DIR=${OUT_DIR:-maps}
VIBROBAR=${VIBROBAR:-vibrobar}    # path to the binary
MAP_ARGS=${MAP_ARGS:-"--preset paper --friction none --ratios 0.90:1.10:0.001 --gaps-mm 0.01:1.0:0.01 --solver rk4 --duration 2"}

mkdir -p "$OUT_DIR" "$OUT_DIR/logs"

array_job=$(sbatch --parsable <<SBATCH
#!/usr/bin/env bash
#SBATCH --job-name=vibrobar-map
#SBATCH --array=1-${N}
#SBATCH --cpus-per-task=8
#SBATCH --time=02:00:00
#SBATCH --output=${OUT_DIR}/logs/map-%A_%a.out
set -euo pipefail
# One shard per array task; threads = the CPUs Slurm gave us.
export RAYON_NUM_THREADS=\${SLURM_CPUS_PER_TASK:-1}
${VIBROBAR} map ${MAP_ARGS} \\
    --shard \${SLURM_ARRAY_TASK_ID}/\${SLURM_ARRAY_TASK_COUNT} \\
    --resume --out ${OUT_DIR}/map.\${SLURM_ARRAY_TASK_ID}.csv
SBATCH
)

sbatch --dependency=afterok:${array_job} <<SBATCH
#!/usr/bin/env bash
#SBATCH --job-name=vibrobar-merge
#SBATCH --cpus-per-task=1
#SBATCH --time=00:20:00
#SBATCH --output=${OUT_DIR}/logs/merge-%j.out
set -euo pipefail
${VIBROBAR} merge --out ${OUT_DIR}/map.csv ${OUT_DIR}/map.[0-9]*.csv
SBATCH

echo "submitted array job ${array_job} (${N} shards) and its merge job"
