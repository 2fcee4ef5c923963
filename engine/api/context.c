// The API's context: a device of its own, the last error, and the bracket every call runs in.
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "api/api_internal.h"

uint32_t penumbra_version(void) { return PENUMBRA_VERSION; }

const char *penumbra_status_string(penumbra_status status)
{
    switch (status) {
    case PENUMBRA_OK: return "PENUMBRA_OK";
    case PENUMBRA_ERROR_INVALID_ARGUMENT: return "PENUMBRA_ERROR_INVALID_ARGUMENT";
    case PENUMBRA_ERROR_IO: return "PENUMBRA_ERROR_IO";
    case PENUMBRA_ERROR_FORMAT: return "PENUMBRA_ERROR_FORMAT";
    case PENUMBRA_ERROR_OUT_OF_MEMORY: return "PENUMBRA_ERROR_OUT_OF_MEMORY";
    case PENUMBRA_ERROR_VULKAN: return "PENUMBRA_ERROR_VULKAN";
    case PENUMBRA_ERROR_UNSUPPORTED: return "PENUMBRA_ERROR_UNSUPPORTED";
    case PENUMBRA_INCOMPLETE: return "PENUMBRA_INCOMPLETE";
    }
    return "unknown status";
}

static pn_log_level log_level(int api_level)
{
    return api_level <= 0 ? PN_LOG_QUIET : api_level == 1 ? PN_LOG_ERROR : api_level == 2 ? PN_LOG_WARN : PN_LOG_INFO;
}

void pn_api_begin(pn_api_call *call, penumbra_context *ctx)
{
    call->ctx = ctx;
    call->message[0] = '\0';
    call->capture = (pn_log_capture){.buf = call->message, .size = sizeof call->message,
                                     .level = log_level(ctx ? ctx->log_level : 0)};
    pn_log_set_capture(&call->capture);
}

penumbra_status pn_api_end(pn_api_call *call, pn_result r)
{
    pn_log_set_capture(NULL);
    static const penumbra_status status[] = {
        [PN_OK] = PENUMBRA_OK,
        [PN_ERR_IO] = PENUMBRA_ERROR_IO,
        [PN_ERR_FORMAT] = PENUMBRA_ERROR_FORMAT,
        [PN_ERR_INVALID] = PENUMBRA_ERROR_INVALID_ARGUMENT,
        [PN_ERR_MEMORY] = PENUMBRA_ERROR_OUT_OF_MEMORY,
        [PN_ERR_VULKAN] = PENUMBRA_ERROR_VULKAN,
        [PN_ERR_UNSUPPORTED] = PENUMBRA_ERROR_UNSUPPORTED,
    };
    penumbra_status s = (unsigned)r < sizeof status / sizeof status[0] ? status[r] : PENUMBRA_ERROR_VULKAN;
    if (s != PENUMBRA_OK && call->ctx)
        snprintf(call->ctx->error, sizeof call->ctx->error, "%s",
                 call->message[0] ? call->message : pn_result_str(r));
    return s;
}

bool pn_api_need(const void *p, const char *fn, const char *name)
{
    if (!p)
        pn_error("%s: %s is NULL", fn, name);
    return p != NULL;
}

bool pn_api_context_ok(const penumbra_context *ctx, const char *fn)
{
    if (!ctx) {
        pn_error("%s: the context is NULL", fn);
        return false;
    }
    if (ctx->closing) {
        pn_error("%s: the context was destroyed (it stays only until its last scene and recorder go)", fn);
        return false;
    }
    if (!ctx->ok)
        pn_error("%s: the context failed at creation (%s)", fn, ctx->error);
    return ctx->ok;
}

penumbra_status penumbra_context_create(const penumbra_context_desc *desc, penumbra_context **out)
{
    if (!out)
        return PENUMBRA_ERROR_INVALID_ARGUMENT; // nowhere to put the message either
    penumbra_context_desc d = desc ? *desc : (penumbra_context_desc){0};
    penumbra_context *ctx = calloc(1, sizeof *ctx);
    *out = ctx;
    if (!ctx)
        return PENUMBRA_ERROR_OUT_OF_MEMORY;
    ctx->log_level = d.log_level;
    pn_api_call call;
    pn_api_begin(&call, ctx);
    pn_gpu_device_desc dd = {.validation = d.validation != 0,
                             .selector = d.device && d.device[0] ? d.device : NULL,
                             .selector_from = "penumbra_context_desc.device"};
    pn_result r = pn_gpu_device_create(&dd, &ctx->dev);
    ctx->ok = r == PN_OK;
    return pn_api_end(&call, r);
}

penumbra_status penumbra_context_create_vulkan(const penumbra_vulkan_desc *vk, const penumbra_context_desc *desc,
                                              penumbra_context **out)
{
    if (!out)
        return PENUMBRA_ERROR_INVALID_ARGUMENT;
    penumbra_context *ctx = calloc(1, sizeof *ctx);
    *out = ctx;
    if (!ctx)
        return PENUMBRA_ERROR_OUT_OF_MEMORY;
    ctx->log_level = desc ? desc->log_level : 0;
    pn_api_call call;
    pn_api_begin(&call, ctx);
    const char *fn = "penumbra_context_create_vulkan";
    if (!pn_api_need(vk, fn, "vulkan"))
        return pn_api_end(&call, PN_ERR_INVALID);
    if (!vk->instance || !vk->physical_device || !vk->device || !vk->queue ||
        (vk->enabled_extension_count && !vk->enabled_extensions)) {
        pn_error("%s: the instance, physical device, device and queue must all be given (and the extension list "
                 "with its count)", fn);
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    pn_gpu_device_adopt_desc ad = {.instance = vk->instance, .physical = vk->physical_device, .device = vk->device,
                                   .queue_family = vk->queue_family, .queue = vk->queue,
                                   .extensions = vk->enabled_extensions, .extension_count = vk->enabled_extension_count};
    pn_result r = pn_gpu_device_adopt(&ad, &ctx->dev);
    ctx->ok = r == PN_OK;
    return pn_api_end(&call, r);
}

static void context_free(penumbra_context *ctx)
{
    if (ctx->ok) {
        pn_api_call call;
        pn_api_begin(&call, ctx);
        pn_gpu_device_destroy(&ctx->dev);
        pn_api_end(&call, PN_OK);
    }
    free(ctx);
}

void penumbra_context_destroy(penumbra_context *ctx)
{
    if (!ctx)
        return;
    ctx->closing = true;
    if (ctx->live == 0)
        context_free(ctx);
}

void pn_api_context_release(penumbra_context *ctx)
{
    if (ctx && --ctx->live == 0 && ctx->closing)
        context_free(ctx);
}

const char *penumbra_context_error(const penumbra_context *ctx)
{
    return ctx ? ctx->error : "no context (penumbra_context_create could not allocate one, or was not called)";
}

const char *penumbra_context_device(const penumbra_context *ctx)
{
    return ctx && ctx->ok ? ctx->dev.props.deviceName : "";
}

uint32_t penumbra_context_validation_messages(const penumbra_context *ctx)
{
    return ctx && ctx->ok ? ctx->dev.validation_messages : 0;
}
