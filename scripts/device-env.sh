# Sourced by the scripts that run on a lent GPU machine (device-bench.sh, device-experiments.sh,
# device-ab.sh): unpacks the Vulkan and EGL loaders carried in .gl/ (scripts/device-prep.sh) where
# the machine has none — unpacking over a system's own could break it — and points them at the
# NVIDIA driver.
if ! ldconfig -p | grep -q 'libvulkan.so.1 '; then
    for f in .gl/*.deb; do dpkg -x "$f" /; done
    ldconfig
fi
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
egl=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
[ -f "$icd" ] && export VK_DRIVER_FILES="$icd"
[ -f "$egl" ] && export __EGL_VENDOR_LIBRARY_FILENAMES="$egl"
