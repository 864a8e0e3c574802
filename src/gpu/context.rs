//! Headless Vulkan: instance (with the Khronos validation layer when asked), device choice,
//! one compute queue, a gpu-allocator, and one-shot command submission.

use std::ffi::{c_void, CStr, CString};
use std::mem::ManuallyDrop;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::{anyhow, bail, Context as _, Result};
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

/// Longest a single submission may run before we call the device lost. A render submits a
/// few passes at a time (see `render::PASS_BATCH_SECONDS`), far below this.
const SUBMIT_TIMEOUT: Duration = Duration::from_secs(600);

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// Case-insensitive substring of the device name to use (`--device`).
    pub device: Option<String>,
    /// Enable the Khronos validation layer and fail on any validation error.
    pub validation: bool,
}

/// A window's Vulkan surface (the preview), owned by the context that presents to it.
pub struct Surface {
    pub loader: ash::khr::surface::Instance,
    pub handle: vk::SurfaceKHR,
}

pub struct Context {
    pub entry: ash::Entry,
    /// The window surface this context presents to (None: headless).
    pub surface: Option<Surface>,
    pub instance: ash::Instance,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    /// Validation errors reported by the layer since the last check (boxed: the callback
    /// holds a raw pointer to it).
    validation_log: Box<Mutex<Vec<String>>>,
    pub physical: vk::PhysicalDevice,
    pub device: ash::Device,
    pub queue: vk::Queue,
    pub queue_family: u32,
    pub allocator: ManuallyDrop<Mutex<Allocator>>,
    command_pool: vk::CommandPool,
    /// Kernels compiled once for the context's life ([`super::pipeline::Compiled`]), by
    /// kernel and specialization, destroyed with the device.
    pub(super) compiled: Mutex<super::pipeline::CompiledCache>,
    /// Kernels compiled so far ([`Context::compiled_kernels`]).
    pub(super) compiles: std::sync::atomic::AtomicUsize,
    pub device_name: String,
    pub device_type: vk::PhysicalDeviceType,
    pub properties: vk::PhysicalDeviceProperties,
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    // The layer's findings only: chained into the instance's creation, the messenger also
    // hears the loader's own errors (a driver file that does not open: a container's
    // nvidia_icd.json without the driver), which failed every `--validation` run there (a
    // review, 2026-12-07).
    if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR)
        && types.contains(vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION)
        && !data.is_null()
    {
        let msg = unsafe { (*data).message_as_c_str() }
            .map(|m| m.to_string_lossy().into_owned())
            .unwrap_or_default();
        let log = unsafe { &*(user as *const Mutex<Vec<String>>) };
        if let Ok(mut l) = log.lock() {
            l.push(msg);
        }
    }
    vk::FALSE
}

fn no_device_help() -> &'static str {
    "Install a Vulkan driver: `ci/setup.sh` installs Mesa's lavapipe (package mesa-vulkan-drivers). \
     If one is installed, check that VK_DRIVER_FILES / VK_ICD_FILENAMES point to existing files."
}

/// Creates a window's surface once the instance exists.
pub type SurfaceMaker<'a> = &'a dyn Fn(&ash::Entry, &ash::Instance) -> Result<vk::SurfaceKHR>;

impl Context {
    /// A headless context: compute only.
    pub fn new(options: &ContextOptions) -> Result<Arc<Context>> {
        Self::create(options, &[], None)
    }

    /// A context that can also present to a window: the instance gets the surface
    /// extensions the window system needs (`instance_extensions`, from ash-window), the
    /// surface is made by `make_surface`, and only a device whose compute queue can present
    /// to it is chosen (others are skipped with their names in the error), with
    /// VK_KHR_swapchain.
    pub fn new_presenting(
        options: &ContextOptions,
        instance_extensions: &[*const i8],
        make_surface: SurfaceMaker,
    ) -> Result<Arc<Context>> {
        Self::create(options, instance_extensions, Some(make_surface))
    }

    fn create(
        options: &ContextOptions,
        instance_extensions: &[*const i8],
        make_surface: Option<SurfaceMaker>,
    ) -> Result<Arc<Context>> {
        // One loader for the process: every context loaded and unloaded libvulkan (and with
        // it the layers and lavapipe) again, which threads creating contexts at once (the
        // tests) do at the same time; one clean-clone run of the suite died with SIGSEGV
        // there once (2026-12-07, not reproduced; a review's suspicion).
        static ENTRY: std::sync::OnceLock<Result<ash::Entry, String>> = std::sync::OnceLock::new();
        let entry = ENTRY
            .get_or_init(|| unsafe { ash::Entry::load() }.map_err(|e| e.to_string()))
            .clone()
            .map_err(|e| {
                anyhow!("cannot load the Vulkan loader (libvulkan.so.1): {e}. Run `ci/setup.sh` (package libvulkan1).")
            })?;
        let app_name = c"lightlearn";
        let app = vk::ApplicationInfo::default()
            .application_name(app_name)
            .engine_name(app_name)
            .api_version(vk::API_VERSION_1_2);

        let mut layers: Vec<*const i8> = Vec::new();
        let mut extensions: Vec<*const i8> = instance_extensions.to_vec();
        if options.validation {
            let available = unsafe { entry.enumerate_instance_layer_properties() }?;
            let found = available
                .iter()
                .any(|l| l.layer_name_as_c_str().ok() == Some(VALIDATION_LAYER));
            if !found {
                bail!("validation was requested but VK_LAYER_KHRONOS_validation is not installed; run `ci/setup.sh` (package vulkan-validationlayers)");
            }
            layers.push(VALIDATION_LAYER.as_ptr());
            extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        let validation_log: Box<Mutex<Vec<String>>> = Box::default();
        let messenger_info = || {
            vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                        | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                        | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
                )
                .pfn_user_callback(Some(debug_callback))
                .user_data(&*validation_log as *const Mutex<Vec<String>> as *mut c_void)
        };
        // Chained into the instance's creation, the messenger also hears what the layer says
        // while the instance is made and destroyed (after the other messenger is gone).
        let mut instance_messenger = messenger_info();
        let mut create = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        if options.validation {
            create = create.push_next(&mut instance_messenger);
        }
        let instance = match unsafe { entry.create_instance(&create, None) } {
            Ok(i) => i,
            Err(vk::Result::ERROR_INCOMPATIBLE_DRIVER) => {
                bail!("no Vulkan driver found. {}", no_device_help())
            }
            Err(e) => bail!("cannot create a Vulkan instance: {e}. {}", no_device_help()),
        };

        let debug = if options.validation {
            let loader = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = messenger_info();
            let messenger = unsafe { loader.create_debug_utils_messenger(&info, None) }?;
            Some((loader, messenger))
        } else {
            None
        };

        let surface = match make_surface.map(|make| make(&entry, &instance)) {
            None => None,
            Some(Ok(handle)) => Some(Surface {
                loader: ash::khr::surface::Instance::new(&entry, &instance),
                handle,
            }),
            Some(Err(e)) => {
                unsafe {
                    if let Some((loader, m)) = &debug {
                        loader.destroy_debug_utils_messenger(*m, None);
                    }
                    instance.destroy_instance(None);
                }
                return Err(e);
            }
        };
        let (physical, queue_family, properties) =
            match pick_device(&instance, options, surface.as_ref()) {
                Ok(p) => p,
                Err(e) => {
                    unsafe {
                        if let Some(s) = &surface {
                            s.loader.destroy_surface(s.handle, None);
                        }
                        if let Some((loader, m)) = &debug {
                            loader.destroy_debug_utils_messenger(*m, None);
                        }
                        instance.destroy_instance(None);
                    }
                    return Err(e);
                }
            };
        let device_name = properties
            .device_name_as_c_str()
            .map(|c| c.to_string_lossy().into_owned())
            .unwrap_or_default();

        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let swapchain_ext = [ash::khr::swapchain::NAME.as_ptr()];
        let device_extensions: &[*const i8] = if surface.is_some() {
            &swapchain_ext
        } else {
            &[]
        };
        let device_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_extension_names(device_extensions);
        let device = unsafe { instance.create_device(physical, &device_info, None) }
            .with_context(|| format!("cannot create a Vulkan device on '{device_name}'"))?;
        let queue = unsafe { device.get_device_queue(queue_family, 0) };

        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })
        .context("cannot create the GPU memory allocator")?;

        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        let command_pool = unsafe { device.create_command_pool(&pool_info, None) }?;

        Ok(Arc::new(Context {
            entry,
            surface,
            instance,
            debug,
            validation_log,
            physical,
            device,
            queue,
            queue_family,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            command_pool,
            compiled: Mutex::new(Default::default()),
            compiles: Default::default(),
            device_name,
            device_type: properties.device_type,
            properties,
        }))
    }

    /// How many kernels this context has compiled (each kernel and specialization once).
    pub fn compiled_kernels(&self) -> usize {
        self.compiles.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Errors reported by the validation layer since the last call, as an `Err`.
    pub fn check_validation(&self) -> Result<()> {
        let mut log = self.validation_log.lock().expect("validation log");
        if log.is_empty() {
            return Ok(());
        }
        let msgs = std::mem::take(&mut *log);
        bail!("Vulkan validation errors:\n{}", msgs.join("\n"))
    }

    /// Records commands with `record`, submits them, waits for completion and checks the
    /// validation layer's verdict.
    pub fn submit(&self, record: impl FnOnce(vk::CommandBuffer)) -> Result<()> {
        let d = &self.device;
        unsafe {
            let alloc = vk::CommandBufferAllocateInfo::default()
                .command_pool(self.command_pool)
                .level(vk::CommandBufferLevel::PRIMARY)
                .command_buffer_count(1);
            let cmd = d.allocate_command_buffers(&alloc)?[0];
            let begin = vk::CommandBufferBeginInfo::default()
                .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            d.begin_command_buffer(cmd, &begin)?;
            record(cmd);
            d.end_command_buffer(cmd)?;
            let fence = d.create_fence(&vk::FenceCreateInfo::default(), None)?;
            let cmds = [cmd];
            let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
            let result = d
                .queue_submit(self.queue, &submit, fence)
                .and_then(|_| d.wait_for_fences(&[fence], true, SUBMIT_TIMEOUT.as_nanos() as u64));
            d.destroy_fence(fence, None);
            d.free_command_buffers(self.command_pool, &cmds);
            match result {
                Ok(()) => {}
                Err(vk::Result::TIMEOUT) => bail!(
                    "the GPU did not finish a submission within {} s; try a smaller image or scene",
                    SUBMIT_TIMEOUT.as_secs()
                ),
                Err(e) => bail!("GPU submission failed: {e} (device lost?)"),
            }
        }
        self.check_validation()
    }

    /// A full memory barrier between compute dispatches (and transfers) in one command buffer;
    /// also orders a dispatch's writes before an indirect dispatch that reads its size.
    pub fn barrier(&self, cmd: vk::CommandBuffer) {
        let barrier = [vk::MemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(
                vk::AccessFlags::SHADER_READ
                    | vk::AccessFlags::SHADER_WRITE
                    | vk::AccessFlags::TRANSFER_READ
                    // A copy or clear over what a kernel or copy wrote (write after write).
                    | vk::AccessFlags::TRANSFER_WRITE
                    | vk::AccessFlags::INDIRECT_COMMAND_READ,
            )];
        unsafe {
            self.device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::COMPUTE_SHADER
                    | vk::PipelineStageFlags::TRANSFER
                    | vk::PipelineStageFlags::DRAW_INDIRECT,
                vk::DependencyFlags::empty(),
                &barrier,
                &[],
                &[],
            );
        }
    }

    /// Makes the transfers recorded before it visible to the host once the submission's
    /// fence is waited on: the wait alone does not (Vulkan's memory model; an audit found
    /// read-backs without it, 2026-12-07: harmless on host-coherent memory, which is what
    /// gpu-allocator gives `GpuToCpu` today, but not promised).
    pub fn host_read_barrier(&self, cmd: vk::CommandBuffer) {
        let barrier = [vk::MemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::HOST_READ)];
        unsafe {
            self.device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::HOST,
                vk::DependencyFlags::empty(),
                &barrier,
                &[],
                &[],
            );
        }
    }

    /// "NAME (discrete GPU, Vulkan 1.3.x)" for reports.
    pub fn describe(&self) -> String {
        let v = self.properties.api_version;
        format!(
            "{} ({}, Vulkan {}.{}.{})",
            self.device_name,
            type_name(self.device_type),
            vk::api_version_major(v),
            vk::api_version_minor(v),
            vk::api_version_patch(v)
        )
    }
}

static STRICT_TEARDOWN: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
static TEARDOWN_ERRORS: Mutex<Vec<String>> = Mutex::new(Vec::new());

/// Makes a context with validation on panic where the layer reports errors while it is
/// destroyed (objects never destroyed): for tests, where a panic fails the test.
pub fn strict_teardown(on: bool) {
    STRICT_TEARDOWN.store(on, std::sync::atomic::Ordering::SeqCst);
}

/// The validation errors reported while contexts were destroyed, since the last call.
pub fn teardown_errors() -> Vec<String> {
    std::mem::take(&mut *TEARDOWN_ERRORS.lock().unwrap_or_else(|e| e.into_inner()))
}

impl Drop for Context {
    fn drop(&mut self) {
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_command_pool(self.command_pool, None);
            if let Ok(cache) = self.compiled.get_mut() {
                for c in cache.values() {
                    c.destroy(&self.device);
                }
            }
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
            if let Some(s) = &self.surface {
                s.loader.destroy_surface(s.handle, None);
            }
            if let Some((loader, m)) = &self.debug {
                loader.destroy_debug_utils_messenger(*m, None);
            }
            self.instance.destroy_instance(None);
        }
        // What the layer said at the end (objects never destroyed: a leak) went into a log
        // that nobody read, so `--validation` and the tests passed over leaks (an audit,
        // 2026-12-07). Drop cannot return an error: the messages wait for
        // [`teardown_errors`] (the command line reports them as its last error line), and
        // under [`strict_teardown`] (the tests) they fail at once.
        let late = self
            .validation_log
            .get_mut()
            .map(std::mem::take)
            .unwrap_or_default();
        if self.debug.is_some() && !late.is_empty() {
            if STRICT_TEARDOWN.load(std::sync::atomic::Ordering::SeqCst)
                && !std::thread::panicking()
            {
                panic!(
                    "Vulkan validation errors while the context was destroyed:\n{}",
                    late.join("\n")
                );
            }
            TEARDOWN_ERRORS
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .extend(late);
        }
    }
}

fn type_name(t: vk::PhysicalDeviceType) -> &'static str {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
        vk::PhysicalDeviceType::CPU => "CPU",
        _ => "other",
    }
}

/// Prefers a discrete GPU, then integrated, virtual, and last a CPU device (lavapipe).
fn pick_device(
    instance: &ash::Instance,
    options: &ContextOptions,
    surface: Option<&Surface>,
) -> Result<(vk::PhysicalDevice, u32, vk::PhysicalDeviceProperties)> {
    let devices = unsafe { instance.enumerate_physical_devices() }?;
    if devices.is_empty() {
        bail!("no Vulkan device found. {}", no_device_help());
    }
    let mut usable = Vec::new();
    let mut names = Vec::new();
    for pd in devices {
        let props = unsafe { instance.get_physical_device_properties(pd) };
        let name = props
            .device_name_as_c_str()
            .map(|c| c.to_string_lossy().into_owned())
            .unwrap_or_default();
        names.push(name.clone());
        if props.api_version < vk::API_VERSION_1_2 {
            continue;
        }
        let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        let presents = |qf: usize| {
            surface.is_none_or(|s| unsafe {
                s.loader
                    .get_physical_device_surface_support(pd, qf as u32, s.handle)
                    .unwrap_or(false)
            })
        };
        let Some(qf) = families
            .iter()
            .enumerate()
            .position(|(i, f)| f.queue_flags.contains(vk::QueueFlags::COMPUTE) && presents(i))
        else {
            if surface.is_some() {
                names.pop();
                names.push(format!("{name} (cannot present to this window)"));
            }
            continue;
        };
        if let Some(want) = &options.device {
            if !name.to_lowercase().contains(&want.to_lowercase()) {
                continue;
            }
        }
        let rank = match props.device_type {
            vk::PhysicalDeviceType::DISCRETE_GPU => 0,
            vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
            vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
            vk::PhysicalDeviceType::CPU => 3,
            _ => 4,
        };
        usable.push((rank, pd, qf as u32, props));
    }
    usable.sort_by_key(|u| u.0);
    match usable.into_iter().next() {
        Some((_, pd, qf, props)) => Ok((pd, qf, props)),
        None => match &options.device {
            Some(want) => bail!(
                "no Vulkan 1.2 compute device matches --device '{want}'. Available: {}",
                names.join(", ")
            ),
            None if surface.is_some() => bail!(
                "no Vulkan 1.2 device can present to this window (found: {}); `lightlearn render` is the headless path",
                names.join(", ")
            ),
            None => bail!(
                "no Vulkan 1.2 device with a compute queue (found: {}). {}",
                names.join(", "),
                no_device_help()
            ),
        },
    }
}

/// Turns a name into a C string for Vulkan debug names (interior NULs dropped).
pub fn c_name(s: &str) -> CString {
    CString::new(s.replace('\0', "")).expect("no interior NUL")
}
