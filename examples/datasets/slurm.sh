#!/usr/bin/env bash
# Render a dataset on a Slurm cluster: every mesh of meshes/ from 100 views around it, split over
# an array of 8 tasks, each on one GPU. The shards are deterministic and together write what one
# run writes; a task that is stopped and requeued skips the views it finished
# (docs/datasets.md#slurm).
#
#   sbatch examples/datasets/slurm.sh
#
#SBATCH --job-name=raycast-dataset
#SBATCH --array=0-7
#SBATCH --gpus-per-task=1
#SBATCH --cpus-per-task=4
#SBATCH --time=01:00:00
#SBATCH --requeue
#SBATCH --output=logs/%x-%A_%a.out
set -euo pipefail
# Every task names the same scenes in the same order: the shard of a task depends on that list.
mapfile -t meshes < <(find meshes -name '*.ply' | sort)
# --shard auto reads SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_MIN and SLURM_ARRAY_TASK_COUNT.
raycast render "${meshes[@]}" --orbit 100 --size 640x480 --format png,npz \
    --shard auto -o /shared/datasets/meshes-orbit
