#pragma once
// Every OpenXR function the runtime implements, with the API's exact signature. They live
// in this namespace (the loader's global xr* symbols are never touched) and reach the app
// only through xrGetInstanceProcAddr (negotiate.cpp). Grouped by the file that defines them.
#include "xr_headers.h"

namespace gauss::xr_headless {

// negotiate.cpp
XrResult xrGetInstanceProcAddr(XrInstance instance, const char* name, PFN_xrVoidFunction* function);

// instance.cpp
XrResult xrEnumerateApiLayerProperties(uint32_t capacity, uint32_t* count, XrApiLayerProperties* properties);
XrResult xrEnumerateInstanceExtensionProperties(const char* layer_name, uint32_t capacity, uint32_t* count,
                                                XrExtensionProperties* properties);
XrResult xrCreateInstance(const XrInstanceCreateInfo* create_info, XrInstance* instance);
XrResult xrDestroyInstance(XrInstance instance);
XrResult xrGetInstanceProperties(XrInstance instance, XrInstanceProperties* properties);
XrResult xrResultToString(XrInstance instance, XrResult value, char buffer[XR_MAX_RESULT_STRING_SIZE]);
XrResult xrStructureTypeToString(XrInstance instance, XrStructureType value,
                                 char buffer[XR_MAX_STRUCTURE_NAME_SIZE]);
XrResult xrStringToPath(XrInstance instance, const char* path_string, XrPath* path);
XrResult xrPathToString(XrInstance instance, XrPath path, uint32_t capacity, uint32_t* count, char* buffer);

// system.cpp
XrResult xrGetSystem(XrInstance instance, const XrSystemGetInfo* get_info, XrSystemId* system_id);
XrResult xrGetSystemProperties(XrInstance instance, XrSystemId system_id, XrSystemProperties* properties);
XrResult xrEnumerateViewConfigurations(XrInstance instance, XrSystemId system_id, uint32_t capacity, uint32_t* count,
                                       XrViewConfigurationType* types);
XrResult xrGetViewConfigurationProperties(XrInstance instance, XrSystemId system_id, XrViewConfigurationType type,
                                          XrViewConfigurationProperties* properties);
XrResult xrEnumerateViewConfigurationViews(XrInstance instance, XrSystemId system_id, XrViewConfigurationType type,
                                           uint32_t capacity, uint32_t* count, XrViewConfigurationView* views);
XrResult xrEnumerateEnvironmentBlendModes(XrInstance instance, XrSystemId system_id, XrViewConfigurationType type,
                                          uint32_t capacity, uint32_t* count, XrEnvironmentBlendMode* modes);

// vulkan_enable2.cpp
XrResult xrGetVulkanGraphicsRequirements2KHR(XrInstance instance, XrSystemId system_id,
                                             XrGraphicsRequirementsVulkanKHR* requirements);
XrResult xrCreateVulkanInstanceKHR(XrInstance instance, const XrVulkanInstanceCreateInfoKHR* create_info,
                                   VkInstance* vulkan_instance, VkResult* vulkan_result);
XrResult xrGetVulkanGraphicsDevice2KHR(XrInstance instance, const XrVulkanGraphicsDeviceGetInfoKHR* get_info,
                                       VkPhysicalDevice* physical_device);
XrResult xrCreateVulkanDeviceKHR(XrInstance instance, const XrVulkanDeviceCreateInfoKHR* create_info,
                                 VkDevice* vulkan_device, VkResult* vulkan_result);

// session.cpp
XrResult xrCreateSession(XrInstance instance, const XrSessionCreateInfo* create_info, XrSession* session);
XrResult xrDestroySession(XrSession session);
XrResult xrBeginSession(XrSession session, const XrSessionBeginInfo* begin_info);
XrResult xrEndSession(XrSession session);
XrResult xrRequestExitSession(XrSession session);

// session_state.cpp
XrResult xrPollEvent(XrInstance instance, XrEventDataBuffer* event_data);

// spaces.cpp
XrResult xrEnumerateReferenceSpaces(XrSession session, uint32_t capacity, uint32_t* count, XrReferenceSpaceType* spaces);
XrResult xrCreateReferenceSpace(XrSession session, const XrReferenceSpaceCreateInfo* create_info, XrSpace* space);
XrResult xrGetReferenceSpaceBoundsRect(XrSession session, XrReferenceSpaceType type, XrExtent2Df* bounds);
XrResult xrCreateActionSpace(XrSession session, const XrActionSpaceCreateInfo* create_info, XrSpace* space);
XrResult xrLocateSpace(XrSpace space, XrSpace base_space, XrTime time, XrSpaceLocation* location);
XrResult xrDestroySpace(XrSpace space);

// views.cpp
XrResult xrLocateViews(XrSession session, const XrViewLocateInfo* locate_info, XrViewState* view_state,
                       uint32_t capacity, uint32_t* count, XrView* views);

// swapchain.cpp
XrResult xrEnumerateSwapchainFormats(XrSession session, uint32_t capacity, uint32_t* count, int64_t* formats);
XrResult xrCreateSwapchain(XrSession session, const XrSwapchainCreateInfo* create_info, XrSwapchain* swapchain);
XrResult xrDestroySwapchain(XrSwapchain swapchain);
XrResult xrEnumerateSwapchainImages(XrSwapchain swapchain, uint32_t capacity, uint32_t* count,
                                    XrSwapchainImageBaseHeader* images);
XrResult xrAcquireSwapchainImage(XrSwapchain swapchain, const XrSwapchainImageAcquireInfo* info, uint32_t* index);
XrResult xrWaitSwapchainImage(XrSwapchain swapchain, const XrSwapchainImageWaitInfo* info);
XrResult xrReleaseSwapchainImage(XrSwapchain swapchain, const XrSwapchainImageReleaseInfo* info);

// frame.cpp
XrResult xrWaitFrame(XrSession session, const XrFrameWaitInfo* wait_info, XrFrameState* frame_state);
XrResult xrBeginFrame(XrSession session, const XrFrameBeginInfo* begin_info);
XrResult xrEndFrame(XrSession session, const XrFrameEndInfo* end_info);

// actions.cpp
XrResult xrCreateActionSet(XrInstance instance, const XrActionSetCreateInfo* create_info, XrActionSet* action_set);
XrResult xrDestroyActionSet(XrActionSet action_set);
XrResult xrCreateAction(XrActionSet action_set, const XrActionCreateInfo* create_info, XrAction* action);
XrResult xrDestroyAction(XrAction action);
XrResult xrSuggestInteractionProfileBindings(XrInstance instance,
                                             const XrInteractionProfileSuggestedBinding* suggested_bindings);
XrResult xrAttachSessionActionSets(XrSession session, const XrSessionActionSetsAttachInfo* attach_info);
XrResult xrGetCurrentInteractionProfile(XrSession session, XrPath top_level_user_path,
                                        XrInteractionProfileState* profile);
XrResult xrEnumerateBoundSourcesForAction(XrSession session, const XrBoundSourcesForActionEnumerateInfo* info,
                                          uint32_t capacity, uint32_t* count, XrPath* sources);
XrResult xrGetInputSourceLocalizedName(XrSession session, const XrInputSourceLocalizedNameGetInfo* info,
                                       uint32_t capacity, uint32_t* count, char* buffer);

// action_state.cpp
XrResult xrSyncActions(XrSession session, const XrActionsSyncInfo* sync_info);
XrResult xrGetActionStateBoolean(XrSession session, const XrActionStateGetInfo* info, XrActionStateBoolean* state);
XrResult xrGetActionStateFloat(XrSession session, const XrActionStateGetInfo* info, XrActionStateFloat* state);
XrResult xrGetActionStateVector2f(XrSession session, const XrActionStateGetInfo* info, XrActionStateVector2f* state);
XrResult xrGetActionStatePose(XrSession session, const XrActionStateGetInfo* info, XrActionStatePose* state);
XrResult xrApplyHapticFeedback(XrSession session, const XrHapticActionInfo* info, const XrHapticBaseHeader* feedback);
XrResult xrStopHapticFeedback(XrSession session, const XrHapticActionInfo* info);

}  // namespace gauss::xr_headless
